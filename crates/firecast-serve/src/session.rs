//! One live fire over one websocket. The simulation steps on its own thread, paced by the
//! page's speed, and hands frames to the socket through a small bounded channel (a slow
//! client slows its own fire, nobody else's). The socket's end — closed by the page, a
//! protocol error, or the fire's end — drops the channels and the thread stops.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{RecvTimeoutError, TryRecvError};
use std::time::{Duration, Instant};

use axum::extract::ws::{CloseFrame, Message, WebSocket};
use serde::Deserialize;

use crate::error::{ApiError, Code};
use crate::fire::{Environment, LiveAgent, LiveRun};

/// Frames a second a run starts at.
const DEFAULT_FPS: u32 = 30;
const MAX_FPS: u32 = 240;
/// WebSocket close code for a message that is not the protocol (RFC 6455, section 7.4.1).
const POLICY_VIOLATION: u16 = 1008;

/// The live fires running, and how many may.
#[derive(Debug)]
pub struct FireSlots {
    running: Arc<AtomicUsize>,
    max: usize,
}

impl FireSlots {
    pub fn new(max: usize) -> Self {
        Self {
            running: Arc::new(AtomicUsize::new(0)),
            max,
        }
    }

    /// Live fires now (`live_fires` in `/api/health`).
    pub fn running(&self) -> usize {
        self.running.load(Ordering::SeqCst)
    }

    /// Takes a slot or answers `busy`.
    pub fn take(&self) -> Result<FireSlot, ApiError> {
        let taken = self.running.fetch_add(1, Ordering::SeqCst);
        if taken >= self.max {
            self.running.fetch_sub(1, Ordering::SeqCst);
            return Err(ApiError::new(
                Code::Busy,
                format!(
                    "{} live fires are running; try again when one has ended",
                    self.max
                ),
            ));
        }
        Ok(FireSlot {
            running: self.running.clone(),
        })
    }
}

/// A live-fire slot, given back when dropped.
pub struct FireSlot {
    running: Arc<AtomicUsize>,
}

impl Drop for FireSlot {
    fn drop(&mut self) {
        self.running.fetch_sub(1, Ordering::SeqCst);
    }
}

/// What the page may send.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum Control {
    Play,
    Pause,
    Step,
    Speed { fps: u32 },
}

/// Parses one text message of the page, or says why it is not the protocol.
pub fn parse_control(text: &str) -> Result<Control, String> {
    let not_protocol = |why: String| {
        format!(
            "not the live-fire protocol ({why}); send {{\"type\": \"play\"|\"pause\"|\"step\"|\"speed\", …}}"
        )
    };
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| not_protocol(e.to_string()))?;
    // serde ignores extra keys beside a tag with no fields: only `type` and `fps` may appear.
    if let Some(key) = value
        .as_object()
        .and_then(|o| o.keys().find(|k| !matches!(k.as_str(), "type" | "fps")))
    {
        return Err(not_protocol(format!("unknown key `{key}`")));
    }
    let control: Control = serde_json::from_value(value).map_err(|e| not_protocol(e.to_string()))?;
    if let Control::Speed { fps } = control
        && fps > MAX_FPS
    {
        return Err(format!(
            "speed {fps} frames a second: at most {MAX_FPS} (0: as fast as computed)"
        ));
    }
    Ok(control)
}

enum Out {
    Frame(Vec<u8>),
    End(String),
}

fn close(reason: &str) -> Message {
    // A close reason is at most 123 bytes.
    let mut reason: String = reason.chars().take(120).collect();
    while reason.len() > 123 {
        reason.pop();
    }
    Message::Close(Some(CloseFrame {
        code: POLICY_VIOLATION,
        reason: reason.into(),
    }))
}

fn error_text(e: &ApiError) -> String {
    serde_json::json!({"type": "error", "code": e.code.as_str(), "message": e.message}).to_string()
}

/// Serves one live fire until the page leaves or the fire ends.
pub async fn run(
    mut socket: WebSocket,
    env: Arc<Environment>,
    agent: LiveAgent,
    seed: u64,
    agent_run: Option<PathBuf>,
    slot: FireSlot,
) {
    let setup_env = env.clone();
    let built = tokio::task::spawn_blocking(move || {
        let (w, h) = (setup_env.setup.landscape.width, setup_env.setup.landscape.height);
        let policy = match agent {
            LiveAgent::Ppo => crate::fire::ppo_policy(agent_run.as_ref(), w, h)?,
            LiveAgent::Rule(kind) => kind.policy(),
        };
        LiveRun::new(&setup_env, agent, policy, seed)
    })
    .await
    .unwrap_or_else(|e| Err(ApiError::internal(format!("starting the fire failed: {e}"))));
    let (mut live, first) = match built {
        Ok(x) => x,
        Err(e) => {
            let _ = socket.send(Message::Text(error_text(&e).into())).await;
            let _ = socket.send(close(&e.message)).await;
            return;
        }
    };
    let start = serde_json::to_string(&live.start).unwrap_or_default();
    if socket.send(Message::Text(start.into())).await.is_err()
        || socket.send(Message::Binary(first.into())).await.is_err()
    {
        return;
    }
    let (ctl_tx, ctl_rx) = std::sync::mpsc::channel::<Control>();
    let (out_tx, mut out_rx) = tokio::sync::mpsc::channel::<Out>(4);
    std::thread::Builder::new()
        .name("firecast-fire".into())
        .spawn(move || step_loop(&mut live, &ctl_rx, &out_tx))
        .ok();
    loop {
        tokio::select! {
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Text(text))) => match parse_control(text.as_str()) {
                    Ok(c) => {
                        if ctl_tx.send(c).is_err() {
                            break;
                        }
                    }
                    Err(reason) => {
                        let _ = socket.send(close(&reason)).await;
                        break;
                    }
                },
                Some(Ok(Message::Binary(_))) => {
                    let _ = socket.send(close("binary messages are not part of the live-fire protocol")).await;
                    break;
                }
                Some(Ok(Message::Ping(_) | Message::Pong(_))) => {}
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => break,
            },
            out = out_rx.recv() => match out {
                Some(Out::Frame(bytes)) => {
                    if socket.send(Message::Binary(bytes.into())).await.is_err() {
                        break;
                    }
                }
                Some(Out::End(text)) => {
                    let _ = socket.send(Message::Text(text.into())).await;
                    let _ = socket.send(Message::Close(None)).await;
                    break;
                }
                None => break,
            },
        }
    }
    // Dropping the control sender and the frame receiver stops the fire's thread.
    drop(ctl_tx);
    drop(out_rx);
    drop(slot);
}

/// Steps the fire: playing at `fps` (0: unpaced), paused until a `step` or `play`.
fn step_loop(
    live: &mut LiveRun,
    controls: &std::sync::mpsc::Receiver<Control>,
    out: &tokio::sync::mpsc::Sender<Out>,
) {
    let mut playing = true;
    let mut fps = DEFAULT_FPS;
    let mut steps_wanted = 0usize;
    let mut next = Instant::now();
    let apply = |c: Control, playing: &mut bool, fps: &mut u32, steps: &mut usize| match c {
        Control::Play => *playing = true,
        Control::Pause => *playing = false,
        Control::Step => *steps += 1,
        Control::Speed { fps: f } => *fps = f,
    };
    loop {
        loop {
            match controls.try_recv() {
                Ok(c) => apply(c, &mut playing, &mut fps, &mut steps_wanted),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        if !playing && steps_wanted == 0 {
            match controls.recv_timeout(Duration::from_millis(200)) {
                Ok(c) => apply(c, &mut playing, &mut fps, &mut steps_wanted),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
            if out.is_closed() {
                return;
            }
            continue;
        }
        if playing && fps > 0 && steps_wanted == 0 {
            let now = Instant::now();
            if next > now {
                // Wait for the tick, still answering the page.
                match controls.recv_timeout(next - now) {
                    Ok(c) => {
                        apply(c, &mut playing, &mut fps, &mut steps_wanted);
                        continue;
                    }
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            }
            let period = Duration::from_secs_f64(1.0 / f64::from(fps));
            // A late tick does not make the next ones hurry to catch up.
            next = next.max(Instant::now() - period) + period;
        }
        steps_wanted = steps_wanted.saturating_sub(1);
        let frame = live.step();
        if out.blocking_send(Out::Frame(frame)).is_err() {
            return;
        }
        if live.is_done() {
            let end = serde_json::to_string(&live.end()).unwrap_or_default();
            let _ = out.blocking_send(Out::End(end));
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_protocol_is_strict() {
        assert_eq!(parse_control(r#"{"type":"play"}"#), Ok(Control::Play));
        assert_eq!(
            parse_control(r#"{"type":"speed","fps":60}"#),
            Ok(Control::Speed { fps: 60 })
        );
        assert!(parse_control(r#"{"type":"speed","fps":1000}"#).is_err());
        assert!(parse_control(r#"{"type":"jump"}"#).is_err());
        assert!(parse_control(r#"{"type":"play","extra":1}"#).is_err());
        assert!(parse_control(r#"{"type":"speed"}"#).is_err());
        assert!(parse_control("hello").is_err());
    }
}
