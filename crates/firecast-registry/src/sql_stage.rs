//! `uses: sql`: a DuckDB query over the stage's inputs (each input is a view named
//! after it: CSV, Parquet or a folder of Parquet), written as one Parquet file and
//! registered as a dataset version.

use std::collections::BTreeMap;

use duckdb::Connection;
use firecast_pipeline::{
    DatasetRecord, ParamsError, Port, Ports, StageContext, StageError, StageKind, typed_params,
};
use serde::{Deserialize, Serialize};

/// Params of a `sql` stage.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SqlParams {
    /// A SELECT; inputs are views named after the input.
    pub query: String,
    /// Dataset name to register the output under (default: the stage name).
    #[serde(default)]
    pub dataset: Option<String>,
}

#[derive(Debug, Default)]
pub struct SqlStage;

const OUTPUTS: &[Port] = &[Port {
    name: "table",
    required: true,
    many: false,
    description: "the query result as a Parquet file",
}];

impl StageKind for SqlStage {
    fn name(&self) -> &'static str {
        "sql"
    }

    fn version(&self) -> u32 {
        1
    }

    fn summary(&self) -> &'static str {
        "DuckDB SQL over CSV/Parquet inputs, written as a Parquet dataset"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: &[],
            outputs: OUTPUTS,
            open: true,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, resolved): (SqlParams, _) = typed_params(raw)?;
        if params.query.trim().is_empty() {
            return Err(ParamsError {
                path: "query".into(),
                message: "the query must not be empty".into(),
            });
        }
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: SqlParams = ctx.params()?;
        let conn = Connection::open_in_memory()?;
        let names: Vec<String> = ctx.input_names().map(str::to_string).collect();
        for name in &names {
            let paths = ctx.input_list(name);
            let files: Vec<String> = paths
                .iter()
                .map(|p| {
                    let s = p.display().to_string();
                    if p.is_dir() {
                        format!("{s}/**/*.parquet")
                    } else {
                        s
                    }
                })
                .map(|s| format!("'{}'", s.replace('\'', "''")))
                .collect();
            let list = format!("[{}]", files.join(", "));
            let reader = if paths.iter().all(|p| p.extension().is_some_and(|e| e == "csv")) {
                format!("read_csv({list}, header = true)")
            } else {
                format!("read_parquet({list})")
            };
            conn.execute_batch(&format!(
                "CREATE VIEW \"{}\" AS SELECT * FROM {reader}",
                name.replace('"', "\"\"")
            ))?;
        }
        let out = ctx.output("table")?;
        let out_sql = out.display().to_string().replace('\'', "''");
        let query = params.query.trim().trim_end_matches(';');
        conn.execute_batch(&format!("COPY ({query}) TO '{out_sql}' (FORMAT parquet)"))?;

        let rows: i64 = conn.query_row(
            &format!("SELECT count(*) FROM read_parquet('{out_sql}')"),
            [],
            |r| r.get(0),
        )?;
        let mut stmt = conn.prepare(&format!("DESCRIBE SELECT * FROM read_parquet('{out_sql}')"))?;
        let schema: Vec<(String, String)> = stmt
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?
            .collect::<Result<_, _>>()?;
        let bytes = std::fs::read(out)?;
        let version = blake3::hash(&bytes).to_hex()[..16].to_string();
        let final_path = ctx
            .root()
            .join(ctx.output_final_path("table").unwrap_or(std::path::Path::new("")));
        ctx.dataset(&DatasetRecord {
            name: params
                .dataset
                .clone()
                .unwrap_or_else(|| ctx.stage().replace('@', "_")),
            version,
            schema_json: serde_json::to_string(
                &schema
                    .iter()
                    .map(|(n, t)| serde_json::json!({"name": n, "type": t}))
                    .collect::<Vec<_>>(),
            )?,
            rows: rows as u64,
            location: final_path.display().to_string(),
            metadata: BTreeMap::from([("query".to_string(), params.query.clone())]),
        });
        ctx.log(format!("{rows} rows"));
        Ok(())
    }
}
