"""Checks a report's GIS files with the libraries GIS users open them with.

    gis_check.py geojson FILE.geojson
        every feature's geometry valid by shapely (OGC rules, GEOS), rings closed, exterior
        rings counter-clockwise and holes clockwise (RFC 7946); with `--area` also that each
        feature's area equals its `cells` property (for grids in cell units).
    gis_check.py rasters REPORT.json ENSEMBLE.json ARRIVAL.tif BURN_PROBABILITY.tif
        both GeoTIFFs opened by rasterio (GDAL): size, CRS, transform and nodata those of the
        ensemble's grid; arrival = the ensemble's median arrival cell by cell; the report's
        isochrone areas, mean burnt area and priority-zone burn probabilities recomputed from
        the rasters (the free fire's, `free_spread`, when the report has one: then ENSEMBLE.json
        is the verified engine's ensemble and the automaton's priority zones are not checked).

Exits non-zero with every finding named.
"""

import json
import math
import sys


def fail(findings):
    if findings:
        sys.exit("\n".join(findings[:40]) + (f"\n… {len(findings)} findings" if len(findings) > 40 else ""))


def check_geojson(path, area):
    import shapely
    from shapely.geometry import shape

    with open(path) as f:
        doc = json.load(f)
    findings = []
    polygons = 0
    for i, feat in enumerate(doc["features"]):
        props = feat.get("properties", {})
        name = f"feature {i} ({props.get('kind')}, {props.get('strategy', '')})"
        geom = feat["geometry"]
        if geom["type"] in ("Polygon", "MultiPolygon"):
            polys = [geom["coordinates"]] if geom["type"] == "Polygon" else geom["coordinates"]
            for p in polys:
                polygons += 1
                for k, ring in enumerate(p):
                    if len(ring) < 4 or ring[0] != ring[-1]:
                        findings.append(f"{name}: ring {k} not closed")
                        continue
                    ccw = shapely.is_ccw(shapely.LinearRing(ring))
                    if ccw != (k == 0):
                        findings.append(f"{name}: ring {k} runs {'counter-' if ccw else ''}clockwise")
        g = shape(geom)
        if not shapely.is_valid(g):
            findings.append(f"{name}: {shapely.is_valid_reason(g)}")
        if area and abs(g.area - props["cells"]) > 1e-9:
            findings.append(f"{name}: area {g.area} for {props['cells']} cells")
    fail(findings)
    print(f"{len(doc['features'])} features, {polygons} polygons valid")


def check_rasters(report_path, ensemble_path, arrival_path, bp_path):
    import numpy as np
    import rasterio

    with open(report_path) as f:
        report = json.load(f)
    with open(ensemble_path) as f:
        ens = json.load(f)
    grid = ens["grid"]
    w, h = grid["width"], grid["height"]
    cell_acres = report["header"]["cell_size_ft"] ** 2 / 43560.0
    findings = []
    bands = {}
    for name, path in (("arrival", arrival_path), ("burn probability", bp_path)):
        with rasterio.open(path) as src:
            if (src.count, src.width, src.height) != (1, w, h):
                findings.append(f"{name}: {src.count} band(s) of {src.width} x {src.height}, grid {w} x {h}")
            if src.dtypes[0] != "float32":
                findings.append(f"{name}: {src.dtypes[0]}")
            epsg = int(grid["crs"].split(":")[1])
            if src.crs is None or src.crs.to_epsg() != epsg:
                findings.append(f"{name}: CRS {src.crs}, grid {grid['crs']}")
            t = src.transform
            want = (grid["cell_size_x"], 0.0, grid["origin_x"], 0.0, -grid["cell_size_y"],
                    grid["origin_y"] + h * grid["cell_size_y"])
            got = (t.a, t.b, t.c, t.d, t.e, t.f)
            if any(abs(a - b) > 1e-9 * max(1.0, abs(b)) for a, b in zip(got, want)):
                findings.append(f"{name}: transform {got}, grid {want}")
            if src.nodata != -9999.0:
                findings.append(f"{name}: nodata {src.nodata}")
            # The ignition: burnt in every run, at the earliest arrival.
            lat, lon = ens["ignition_lat_lon"]
            row, col = src.index(lon, lat)
            bands[name] = (src.read(1, masked=True), (row, col))
    arrival, (irow, icol) = bands["arrival"]
    bp, _ = bands["burn probability"]
    # North-up rasters; the ensemble's cells run from the south row.
    median = ens["arrival_median_h"]
    for y in range(h):
        for x in range(w):
            v = arrival[h - 1 - y, x]
            m = median[y * w + x]
            if (m is None) != bool(np.ma.is_masked(v)) or (m is not None and abs(float(v) - m) > 1e-4):
                findings.append(f"arrival at cell ({x}, {y}): raster {v}, ensemble {m}")
            p = ens["burn_count"][y * w + x] * 100.0 / len(ens["episodes"])
            if abs(float(bp[h - 1 - y, x]) - p) > 1e-4:
                findings.append(f"burn probability at cell ({x}, {y}): raster {bp[h - 1 - y, x]}, ensemble {p}")
    if bp.mask.any():
        findings.append("burn probability has nodata cells")
    if abs(float(bp[irow, icol]) - 100.0) > 1e-6:
        findings.append(f"burn probability at the ignition {bp[irow, icol]}")
    if float(arrival[irow, icol]) != float(arrival.min()):
        findings.append(f"arrival at the ignition {arrival[irow, icol]}, earliest {arrival.min()}")
    # The rasters draw the free fire: the verified engine's when the report has it (then the
    # priority zones, which are the automaton's, are not in the rasters).
    free = report.get("free_spread")
    none = free["fire"] if free else next(s for s in report["strategies"] if s["strategy"] == "none")
    for t, acres in none["isochrone_acres"]:
        got = float(((arrival <= t).filled(False)).sum()) * cell_acres
        if abs(got - acres) > 1e-6 * max(1.0, acres):
            findings.append(f"isochrone {t} h: {got} acres in the raster, {acres} in the report")
    mean = float(bp.astype("float64").sum()) / 100.0 * cell_acres
    if abs(mean - none["burned_acres"]["value"]) > 1e-4 * max(1.0, mean):
        findings.append(f"mean burnt area {mean} acres from the raster, {none['burned_acres']['value']} in the report")
    for z in [] if free else report["priority_zones"]:
        x0, y0, x1, y1 = z["cells"]
        block = bp[h - y1:h - y0, x0:x1].astype("float64")
        if abs(float(block.mean()) - z["burn_probability_unsuppressed_pct"]) > 1e-4:
            findings.append(f"priority zone {z['rank']}: {block.mean()} % in the raster, "
                            f"{z['burn_probability_unsuppressed_pct']} in the report")
    fail(findings)
    print(f"rasters {w} x {h} agree with the report ({len(none['isochrone_acres'])} isochrones, "
          f"{len(report['priority_zones'])} zones)")


if __name__ == "__main__":
    what, *args = sys.argv[1:]
    if what == "geojson":
        check_geojson(args[0], "--area" in args[1:])
    elif what == "rasters":
        check_rasters(*args)
    else:
        sys.exit(f"unknown check {what}")
