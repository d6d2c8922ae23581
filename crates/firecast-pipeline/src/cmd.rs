//! The generic `cmd` stage kind: a shell command with declared inputs and outputs,
//! as in DVC. `${inputs.NAME}` and `${outputs.NAME}` in the command expand to
//! shell-quoted paths; outputs point at temporary names, so a command that dies
//! half-way never leaves a file that looks finished.
//!
//! `$FIRECAST_BIN` is the running `firecast`, so commands can call it without a PATH.
//! Metrics: the command may append lines `KEY VALUE` or `KEY STEP VALUE` to the file
//! named by `$FIRECAST_METRICS`; they are recorded in the run registry.

use std::collections::BTreeMap;
use std::io::{BufRead as _, BufReader};
use std::process::{Command, Stdio};

use serde::{Deserialize, Serialize};

use crate::error::StageError;
use crate::stage::{ParamsError, Ports, StageContext, StageKind, typed_params};

/// Params of a `cmd` stage.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CmdParams {
    /// Run with `sh -c`, in the project root.
    pub command: String,
    /// Extra environment variables for the command.
    #[serde(default)]
    pub env: BTreeMap<String, String>,
}

/// `uses: cmd`.
#[derive(Debug, Default)]
pub struct CmdStage;

impl StageKind for CmdStage {
    fn name(&self) -> &'static str {
        "cmd"
    }

    fn version(&self) -> u32 {
        1
    }

    fn summary(&self) -> &'static str {
        "run a shell command with declared inputs and outputs"
    }

    fn ports(&self) -> Ports {
        Ports {
            inputs: &[],
            outputs: &[],
            open: true,
        }
    }

    fn resolve_params(&self, raw: &serde_json::Value) -> Result<serde_json::Value, ParamsError> {
        let (params, resolved): (CmdParams, _) = typed_params(raw)?;
        if params.command.trim().is_empty() {
            return Err(ParamsError {
                path: "command".into(),
                message: "the command must not be empty".into(),
            });
        }
        Ok(resolved)
    }

    fn run(&self, ctx: &mut StageContext<'_>) -> Result<(), StageError> {
        let params: CmdParams = ctx.params()?;
        let command = expand_placeholders(&params.command, ctx)?;
        ctx.log(format!("$ {command}"));
        let metrics_file = std::env::temp_dir().join(format!("firecast-metrics-{}.txt", ctx.run_id()));
        let mut child = Command::new("sh");
        child
            .arg("-c")
            .arg(&command)
            .current_dir(ctx.root())
            .env("FIRECAST_ROOT", ctx.root())
            .env("FIRECAST_STAGE", ctx.stage())
            .env("FIRECAST_RUN_ID", ctx.run_id())
            .env("FIRECAST_METRICS", &metrics_file)
            .env(
                "FIRECAST_BIN",
                std::env::current_exe().unwrap_or_else(|_| "firecast".into()),
            )
            .envs(&params.env)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        die_with_parent(&mut child);
        let mut child = child
            .spawn()
            .map_err(|e| StageError::msg(format!("cannot start `sh`: {e}")))?;
        let stdout = child.stdout.take();
        let stderr = child.stderr.take();
        let lines = std::sync::Mutex::new(Vec::new());
        std::thread::scope(|scope| {
            if let Some(out) = stdout {
                let lines = &lines;
                scope.spawn(move || collect(out, lines));
            }
            if let Some(err) = stderr {
                let lines = &lines;
                scope.spawn(move || collect(err, lines));
            }
        });
        let status = child
            .wait()
            .map_err(|e| StageError::msg(format!("waiting for the command: {e}")))?;
        let lines = lines.into_inner().unwrap_or_else(|e| e.into_inner());
        for line in &lines {
            ctx.log(line.clone());
        }
        let metrics = std::fs::read_to_string(&metrics_file).unwrap_or_default();
        let _ignored = std::fs::remove_file(&metrics_file);
        if status.success() {
            return record_metrics(ctx, &metrics);
        }
        let tail: Vec<&str> = lines.iter().rev().take(10).rev().map(String::as_str).collect();
        let code = status
            .code()
            .map_or_else(|| "a signal".to_string(), |c| format!("code {c}"));
        Err(StageError::msg(if tail.is_empty() {
            format!("command exited with {code}")
        } else {
            format!(
                "command exited with {code}; last output:\n  {}",
                tail.join("\n  ")
            )
        }))
    }
}

/// Parse `KEY VALUE` / `KEY STEP VALUE` lines written by the command.
fn record_metrics(ctx: &StageContext<'_>, text: &str) -> Result<(), StageError> {
    for (number, line) in text.lines().enumerate() {
        let fields: Vec<&str> = line.split_whitespace().collect();
        let parsed = match fields.as_slice() {
            [] => continue,
            [key, value] => value.parse::<f64>().ok().map(|v| (*key, 0, v)),
            [key, step, value] => match (step.parse::<i64>(), value.parse::<f64>()) {
                (Ok(s), Ok(v)) => Some((*key, s, v)),
                _ => None,
            },
            _ => None,
        };
        let (key, step, value) = parsed.ok_or_else(|| {
            StageError::msg(format!(
                "$FIRECAST_METRICS line {}: expected `KEY VALUE` or `KEY STEP VALUE`, got `{line}`",
                number + 1
            ))
        })?;
        ctx.metric(key, step, value);
    }
    Ok(())
}

fn collect(reader: impl std::io::Read, lines: &std::sync::Mutex<Vec<String>>) {
    for line in BufReader::new(reader).lines().map_while(Result::ok) {
        lines.lock().unwrap_or_else(|e| e.into_inner()).push(line);
    }
}

/// Replace `${inputs.X}` / `${outputs.X}` with quoted paths.
fn expand_placeholders(command: &str, ctx: &StageContext<'_>) -> Result<String, StageError> {
    let mut out = String::with_capacity(command.len());
    let mut rest = command;
    while let Some(pos) = rest.find("${") {
        out.push_str(&rest[..pos]);
        let after = &rest[pos + 2..];
        let Some(end) = after.find('}') else {
            out.push_str(&rest[pos..]);
            return Ok(out);
        };
        let name = after[..end].trim();
        if let Some(input) = name.strip_prefix("inputs.") {
            let paths = ctx.input_list(input);
            if paths.is_empty() {
                return Err(StageError::msg(format!(
                    "`${{{name}}}`: no input `{input}` is declared"
                )));
            }
            let quoted: Vec<String> = paths
                .iter()
                .map(|p| shell_quote(&p.display().to_string()))
                .collect();
            out.push_str(&quoted.join(" "));
        } else if let Some(output) = name.strip_prefix("outputs.") {
            let path = ctx
                .output(output)
                .map_err(|_| StageError::msg(format!("`${{{name}}}`: no output `{output}` is declared")))?;
            out.push_str(&shell_quote(&path.display().to_string()));
        } else {
            // Left for the shell (e.g. `${HOME}`).
            out.push_str(&rest[pos..pos + 2 + end + 1]);
        }
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:@".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The command must not outlive `firecast`: if firecast is killed, so is the command
/// (otherwise it would keep writing a temporary output nobody will publish).
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn die_with_parent(command: &mut Command) {
    use std::os::unix::process::CommandExt as _;
    // SAFETY: prctl is async-signal-safe and touches no memory of the parent.
    unsafe {
        command.pre_exec(|| {
            if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
}

#[cfg(not(target_os = "linux"))]
fn die_with_parent(_command: &mut Command) {}

#[cfg(test)]
mod tests {
    use super::shell_quote;

    #[test]
    fn quotes_only_when_needed() {
        assert_eq!(shell_quote("data/a.csv"), "data/a.csv");
        assert_eq!(shell_quote("my file"), "'my file'");
        assert_eq!(shell_quote("it's"), r"'it'\''s'");
    }
}
