//! The artifact store against a real S3-compatible server (moto, started by the test on
//! loopback), and the default local folder.

use std::net::TcpListener;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::{Project, describe, venv_bin};

/// A moto S3 server on a free loopback port, killed on drop.
pub(crate) struct Moto {
    child: Child,
    endpoint: String,
}

impl Moto {
    pub(crate) fn start() -> Self {
        let port = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let server = venv_bin("moto_server");
        let child = Command::new(server)
            .args(["-H", "127.0.0.1", "-p", &port.to_string()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let deadline = Instant::now() + Duration::from_secs(60);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(Instant::now() < deadline, "moto did not start");
            std::thread::sleep(Duration::from_millis(100));
        }
        Self {
            child,
            endpoint: format!("http://127.0.0.1:{port}"),
        }
    }

    pub(crate) fn create_bucket(&self, bucket: &str) {
        let status = Command::new(venv_bin("python"))
            .args([
                "-c",
                "import boto3, sys; boto3.client('s3', endpoint_url=sys.argv[1], region_name='us-east-1', \
                 aws_access_key_id='test', aws_secret_access_key='test').create_bucket(Bucket=sys.argv[2])",
                &self.endpoint,
                bucket,
            ])
            .status()
            .unwrap();
        assert!(status.success());
    }

    pub(crate) fn env(&self, cmd: &mut Command) {
        cmd.env("AWS_ENDPOINT_URL", &self.endpoint)
            .env("AWS_ALLOW_HTTP", "true")
            .env("AWS_REGION", "us-east-1")
            .env("AWS_ACCESS_KEY_ID", "test")
            .env("AWS_SECRET_ACCESS_KEY", "test")
            .env_remove("AWS_PROFILE")
            .env_remove("AWS_SESSION_TOKEN");
    }
}

impl Drop for Moto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn s3_round_trip_through_pipeline_artifacts_and_url_inputs() {
    let moto = Moto::start();
    moto.create_bucket("wildfire");
    let p = Project::new();
    p.write(
        "pipelines/s3.yaml",
        "stages:\n  report:\n    uses: cmd\n    params: {command: \"printf 'threat: HIGH\\n' > ${outputs.md}\"}\n    outputs: {md: {path: reports/threat.md, artifact: true}}\n",
    );
    let run = |args: &[&str]| {
        let mut cmd = p.firecast();
        moto.env(&mut cmd);
        let out = cmd
            .arg("--store")
            .arg("s3://wildfire/team")
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "firecast {args:?}:\n{}", describe(&out));
        out
    };
    run(&["pipeline", "run", "pipelines/s3.yaml"]);

    let listed: serde_json::Value =
        serde_json::from_slice(&run(&["--json", "artifacts", "ls", "runs"]).stdout).unwrap();
    let listed = listed.as_array().unwrap();
    assert_eq!(listed.len(), 1, "{listed:?}");
    let uri = listed[0]["uri"].as_str().unwrap().to_string();
    assert!(
        uri.starts_with("s3://wildfire/team/runs/") && uri.ends_with("/md/threat.md"),
        "{uri}"
    );
    assert_eq!(listed[0]["size"], 13);

    run(&["artifacts", "get", &uri, "-o", "downloaded.md"]);
    assert_eq!(p.read("downloaded.md"), "threat: HIGH\n");

    // The same object as a pipeline input by URL.
    p.write(
        "pipelines/reader.yaml",
        &format!(
            "stages:\n  read:\n    uses: cmd\n    params: {{command: \"tr a-z A-Z < ${{inputs.doc}} > ${{outputs.out}}\"}}\n    inputs: {{doc: \"{uri}\"}}\n    outputs: {{out: upper.md}}\n"
        ),
    );
    run(&["pipeline", "run", "pipelines/reader.yaml"]);
    assert_eq!(p.read("upper.md"), "THREAT: HIGH\n");

    // A key that does not exist is a clear error.
    let mut cmd = p.firecast();
    moto.env(&mut cmd);
    let out = cmd
        .args([
            "--store",
            "s3://wildfire/team",
            "artifacts",
            "get",
            "runs/nope/x.md",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("artifact not found: s3://wildfire/team/runs/nope/x.md"),
        "{}",
        describe(&out)
    );
}

#[test]
fn local_artifact_folder_is_the_default() {
    let p = Project::new();
    p.write(
        "pipelines/a.yaml",
        "stages:\n  model:\n    uses: cmd\n    params: {command: \"echo weights > ${outputs.w}\"}\n    outputs: {w: {path: out/weights.txt, artifact: true}}\n",
    );
    p.run_pipeline("pipelines/a.yaml", &[]);
    let listed = p.json(&["artifacts", "ls"]);
    let key = listed[0]["key"].as_str().unwrap();
    assert!(
        key.starts_with("runs/") && key.ends_with("/w/weights.txt"),
        "{key}"
    );
    assert_eq!(
        std::fs::read_to_string(p.path(&format!("artifacts/{key}"))).unwrap(),
        "weights\n"
    );
}
