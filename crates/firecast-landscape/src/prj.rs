//! The coordinate system of a `.prj` sidecar (ESRI or OGC WKT 1, as GDAL's LCP driver and
//! ArcGIS write it), identified without PROJ: an `AUTHORITY["EPSG", …]` / `ID["EPSG", …]` on
//! the top-level CRS; otherwise, by its parameters, the CRSs fire landscapes come in — NAD83
//! CONUS Albers (EPSG:5070, LANDFIRE's, which ESRI writes as `NAD_1983_Contiguous_USA_Albers`
//! with no code) and UTM zones on WGS84 (EPSG:326zz/327zz) or NAD83 (EPSG:269zz). Anything else
//! projected is kept by name as `USER-DEFINED:<name>`; a geographic CRS is reported as such
//! (a fire landscape needs a projected grid).

/// What a `.prj` says.
#[derive(Debug, Clone, PartialEq)]
pub struct PrjCrs {
    /// `EPSG:nnnn`, or `USER-DEFINED:<name>` when the CRS has no code we can identify.
    pub crs: String,
    /// The EPSG code, where identified.
    pub epsg: Option<u16>,
    /// The CRS's name (`PROJCS["…"`).
    pub name: String,
    /// Whether it is a geographic (latitude/longitude) CRS.
    pub geographic: bool,
    /// The linear unit's length in metres (1 for metres, 0.3048 for feet), where stated.
    pub metres_per_unit: Option<f64>,
}

/// One WKT node: `KEYWORD[item, item, …]`.
#[derive(Debug, Clone, PartialEq)]
enum Item {
    Text(String),
    Number(f64),
    Node(Node),
}

#[derive(Debug, Clone, PartialEq)]
struct Node {
    keyword: String,
    items: Vec<Item>,
}

impl Node {
    fn children<'a, 'k>(&'a self, keyword: &'k str) -> impl Iterator<Item = &'a Node> + use<'a, 'k> {
        self.items.iter().filter_map(move |i| match i {
            Item::Node(n) if n.keyword.eq_ignore_ascii_case(keyword) => Some(n),
            _ => None,
        })
    }

    fn child(&self, keyword: &str) -> Option<&Node> {
        self.children(keyword).next()
    }

    fn text(&self, k: usize) -> Option<&str> {
        match self.items.get(k)? {
            Item::Text(s) => Some(s),
            _ => None,
        }
    }

    fn number(&self, k: usize) -> Option<f64> {
        match self.items.get(k)? {
            Item::Number(v) => Some(*v),
            Item::Text(s) => s.trim().parse().ok(),
            Item::Node(_) => None,
        }
    }

    /// `AUTHORITY["EPSG","5070"]` (WKT 1) or `ID["EPSG",5070]` (WKT 2) directly under this node.
    fn epsg(&self) -> Option<u16> {
        self.children("AUTHORITY")
            .chain(self.children("ID"))
            .find(|a| a.text(0).is_some_and(|s| s.eq_ignore_ascii_case("EPSG")))
            .and_then(|a| a.number(1))
            .filter(|c| c.fract() == 0.0 && (1.0..=65535.0).contains(c))
            .map(|c| c as u16)
    }
}

/// Parse a WKT string into its top-level node.
fn parse(text: &str) -> Result<Node, String> {
    let chars: Vec<char> = text.chars().collect();
    let mut pos = 0;
    let Item::Node(node) = parse_word(&chars, &mut pos)? else {
        return Err("expected a WKT node such as PROJCS[...]".into());
    };
    skip_ws(&chars, &mut pos);
    if pos != chars.len() {
        return Err(format!(
            "unexpected text after the top-level node at character {pos}"
        ));
    }
    Ok(node)
}

fn skip_ws(c: &[char], pos: &mut usize) {
    while *pos < c.len() && c[*pos].is_whitespace() {
        *pos += 1;
    }
}

/// A keyword with its bracketed items (a node), or a bare word (`EAST` in `AXIS["x",EAST]`).
fn parse_word(c: &[char], pos: &mut usize) -> Result<Item, String> {
    skip_ws(c, pos);
    let start = *pos;
    while *pos < c.len() && (c[*pos].is_ascii_alphanumeric() || c[*pos] == '_') {
        *pos += 1;
    }
    if *pos == start {
        return Err(format!("expected a WKT keyword at character {start}"));
    }
    let keyword: String = c[start..*pos].iter().collect();
    skip_ws(c, pos);
    let close = match c.get(*pos) {
        Some('[') => ']',
        Some('(') => ')',
        _ => return Ok(Item::Text(keyword)),
    };
    *pos += 1;
    let mut items = Vec::new();
    loop {
        skip_ws(c, pos);
        match c.get(*pos) {
            None => return Err(format!("{keyword}[ is not closed")),
            Some(ch) if *ch == close => {
                *pos += 1;
                break;
            }
            Some(',') if !items.is_empty() => {
                *pos += 1;
                continue;
            }
            Some('"') => {
                *pos += 1;
                let mut s = String::new();
                loop {
                    match c.get(*pos) {
                        None => return Err("unterminated string".into()),
                        Some('"') if c.get(*pos + 1) == Some(&'"') => {
                            s.push('"');
                            *pos += 2;
                        }
                        Some('"') => {
                            *pos += 1;
                            break;
                        }
                        Some(ch) => {
                            s.push(*ch);
                            *pos += 1;
                        }
                    }
                }
                items.push(Item::Text(s));
            }
            Some(ch) if ch.is_ascii_digit() || *ch == '-' || *ch == '+' || *ch == '.' => {
                let start = *pos;
                while *pos < c.len() && (c[*pos].is_ascii_alphanumeric() || "+-.".contains(c[*pos])) {
                    *pos += 1;
                }
                let s: String = c[start..*pos].iter().collect();
                items.push(Item::Number(
                    s.parse().map_err(|_| format!("{s:?} is not a number"))?,
                ));
            }
            Some(_) => items.push(parse_word(c, pos)?),
        }
    }
    Ok(Item::Node(Node { keyword, items }))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

/// A parameter by any of its names (ESRI and OGC spell them differently), case-insensitive.
fn parameter(node: &Node, names: &[&str]) -> Option<f64> {
    node.children("PARAMETER")
        .find(|p| {
            p.text(0)
                .is_some_and(|n| names.iter().any(|m| n.eq_ignore_ascii_case(m)))
        })
        .and_then(|p| p.number(1))
}

fn datum_is(node: &Node, fragments: &[&str]) -> bool {
    let datum = node
        .child("GEOGCS")
        .and_then(|g| g.child("DATUM"))
        .and_then(|d| d.text(0))
        .unwrap_or_default()
        .to_ascii_lowercase()
        .replace([' ', '-'], "_");
    fragments.iter().any(|f| datum.contains(f))
}

/// NAD83 / CONUS Albers (EPSG:5070) by its parameters.
fn is_conus_albers(node: &Node) -> bool {
    let projection = node
        .child("PROJECTION")
        .and_then(|p| p.text(0))
        .unwrap_or_default()
        .to_ascii_lowercase();
    let value = |names: &[&str], want: f64| parameter(node, names).is_some_and(|v| close(v, want));
    projection.starts_with("albers")
        && datum_is(node, &["north_american_1983", "north_american_datum_1983"])
        && value(&["central_meridian", "longitude_of_center"], -96.0)
        && value(&["standard_parallel_1"], 29.5)
        && value(&["standard_parallel_2"], 45.5)
        && value(&["latitude_of_origin", "latitude_of_center"], 23.0)
        && value(&["false_easting"], 0.0)
        && value(&["false_northing"], 0.0)
}

/// A UTM zone on WGS84 or NAD83, by name and parameters: EPSG:326zz / 327zz / 269zz.
fn utm_code(node: &Node, name: &str) -> Option<u16> {
    let lower = name.to_ascii_lowercase().replace([' ', '/'], "_");
    let at = lower.find("utm_zone_")?;
    let rest = &lower[at + "utm_zone_".len()..];
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    let zone: u16 = digits.parse().ok().filter(|z| (1..=60).contains(z))?;
    let north = match rest[digits.len()..].chars().next()? {
        'n' => true,
        's' => false,
        _ => return None,
    };
    let value = |names: &[&str], want: f64| parameter(node, names).is_none_or(|v| close(v, want));
    let cm = f64::from(zone) * 6.0 - 183.0;
    let consistent = value(&["central_meridian", "longitude_of_center"], cm)
        && value(&["scale_factor"], 0.9996)
        && value(&["false_easting"], 500_000.0)
        && value(&["false_northing"], if north { 0.0 } else { 10_000_000.0 });
    if !consistent {
        return None;
    }
    if datum_is(node, &["wgs_1984", "world_geodetic_system_1984"])
        || lower.starts_with("wgs_1984")
        || lower.starts_with("wgs_84")
    {
        Some(if north { 32600 + zone } else { 32700 + zone })
    } else if (datum_is(node, &["north_american_1983", "north_american_datum_1983"])
        || lower.starts_with("nad_1983")
        || lower.starts_with("nad83"))
        && north
        && zone <= 23
    {
        Some(26900 + zone)
    } else {
        None
    }
}

/// Identify the CRS of a `.prj`'s text.
pub fn identify(text: &str) -> Result<PrjCrs, String> {
    let trimmed = text.trim_start_matches('\u{feff}').trim();
    let node = parse(trimmed)?;
    let keyword = node.keyword.to_ascii_uppercase();
    let name = node.text(0).unwrap_or_default().to_string();
    let geographic = matches!(
        keyword.as_str(),
        "GEOGCS" | "GEOGCRS" | "GEODCRS" | "GEOGRAPHICCRS"
    );
    let projected = matches!(keyword.as_str(), "PROJCS" | "PROJCRS" | "PROJECTEDCRS");
    if !geographic && !projected {
        return Err(format!(
            "{keyword}[…] is neither a projected (PROJCS) nor a geographic (GEOGCS) CRS"
        ));
    }
    let metres_per_unit = node
        .children("UNIT")
        .chain(node.children("LENGTHUNIT"))
        .next()
        .and_then(|u| u.number(1));
    let epsg = node.epsg().or_else(|| {
        if !projected {
            let datum_wgs84 = node.child("DATUM").and_then(|d| d.text(0)).is_some_and(|d| {
                d.to_ascii_lowercase().contains("wgs_1984") || d.to_ascii_lowercase().contains("wgs 84")
            });
            return (datum_wgs84 || name.eq_ignore_ascii_case("GCS_WGS_1984")).then_some(4326);
        }
        if is_conus_albers(&node) && metres_per_unit.is_none_or(|m| close(m, 1.0)) {
            return Some(5070);
        }
        utm_code(&node, &name).filter(|_| metres_per_unit.is_none_or(|m| close(m, 1.0)))
    });
    let crs = match epsg {
        Some(code) => format!("EPSG:{code}"),
        None => format!("USER-DEFINED:{name}"),
    };
    Ok(PrjCrs {
        crs,
        epsg,
        name,
        geographic,
        metres_per_unit,
    })
}

/// GeoTIFF key tags for a projected CRS: GTModelType projected, PixelIsArea, and the EPSG code
/// (ProjectedCSTypeGeoKey) or, with none, user-defined (32767) with the name as the PCS
/// citation — what [`crate::gridio::encode_geotiff_f32`] copies into written grids.
pub fn geokeys(crs: &PrjCrs) -> crate::gridio::GeoKeyTags {
    match crs.epsg {
        Some(code) => crate::gridio::GeoKeyTags {
            directory: vec![1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, code],
            doubles: Vec::new(),
            ascii: String::new(),
        },
        None => {
            let ascii = format!("{}|", crs.name);
            crate::gridio::GeoKeyTags {
                directory: vec![
                    1,
                    1,
                    0,
                    4,
                    1024,
                    0,
                    1,
                    1,
                    1025,
                    0,
                    1,
                    1,
                    3072,
                    0,
                    1,
                    32767,
                    3073,
                    34737,
                    ascii.len() as u16,
                    0,
                ],
                doubles: Vec::new(),
                ascii,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What GDAL's LCP driver writes for EPSG:5070 (ESRI WKT, no code).
    const ESRI_5070: &str = r#"PROJCS["NAD_1983_Contiguous_USA_Albers",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Albers"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-96.0],PARAMETER["Standard_Parallel_1",29.5],PARAMETER["Standard_Parallel_2",45.5],PARAMETER["Latitude_Of_Origin",23.0],UNIT["Meter",1.0]]"#;

    #[test]
    fn esri_conus_albers_is_5070() {
        let crs = identify(ESRI_5070).expect("parses");
        assert_eq!(crs.crs, "EPSG:5070");
        assert!(!crs.geographic);
        assert_eq!(crs.metres_per_unit, Some(1.0));
        // Another standard parallel: not 5070, kept by name.
        let other = identify(&ESRI_5070.replace("45.5", "45.0")).expect("parses");
        assert_eq!(other.crs, "USER-DEFINED:NAD_1983_Contiguous_USA_Albers");
    }

    #[test]
    fn ogc_authority_wins() {
        let ogc = r#"PROJCS["NAD83 / Conus Albers",GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101,AUTHORITY["EPSG","7019"]],AUTHORITY["EPSG","6269"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433],AUTHORITY["EPSG","4269"]],PROJECTION["Albers_Conic_Equal_Area"],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AUTHORITY["EPSG","5070"]]"#;
        assert_eq!(identify(ogc).expect("parses").epsg, Some(5070));
    }

    #[test]
    fn utm_and_geographic() {
        let utm = r#"PROJCS["WGS_1984_UTM_Zone_11N",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",500000.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-117.0],PARAMETER["Scale_Factor",0.9996],PARAMETER["Latitude_Of_Origin",0.0],UNIT["Meter",1.0]]"#;
        assert_eq!(identify(utm).expect("parses").crs, "EPSG:32611");
        let nad = utm
            .replace("WGS_1984_UTM", "NAD_1983_UTM")
            .replace("D_WGS_1984", "D_North_American_1983");
        assert_eq!(identify(&nad).expect("parses").crs, "EPSG:26911");
        // A zone whose central meridian disagrees is not guessed.
        assert!(
            identify(&utm.replace("-117.0", "-111.0"))
                .expect("parses")
                .epsg
                .is_none()
        );
        let geo = r#"GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]]"#;
        let g = identify(geo).expect("parses");
        assert!(g.geographic);
        assert_eq!(g.crs, "EPSG:4326");
    }

    #[test]
    fn malformed_text_is_an_error() {
        assert!(identify("PROJCS[\"x\",").is_err());
        assert!(identify("hello").is_err());
        assert!(identify(r#"VERT_CS["x"]"#).is_err());
    }

    #[test]
    fn geokeys_carry_the_code_or_the_name() {
        let keys = geokeys(&identify(ESRI_5070).expect("parses"));
        assert_eq!(&keys.directory[12..16], &[3072, 0, 1, 5070]);
        let user = geokeys(&identify(&ESRI_5070.replace("45.5", "45.0")).expect("parses"));
        assert_eq!(user.ascii, "NAD_1983_Contiguous_USA_Albers|");
        assert_eq!(user.directory[3], 4);
    }
}
