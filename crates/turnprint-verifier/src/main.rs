//! The visual verifier sidecar: receives keyframes and loop-closure candidates
//! from a detector over iceoryx2, decides each candidate with ORB features and
//! relative-pose geometry, and sends verdicts back.
//!
//! ```text
//! turnprint-verifier --prefix NAME [--max-memory-mb N] [--heartbeat-ms N] [--report-secs N]
//! ```
//!
//! Runs until SIGINT/SIGTERM. Statistics go to stderr every `--report-secs`
//! seconds (0: never) and at exit; the same counters reach clients in the
//! status heartbeat.

use std::process::ExitCode;
use std::time::Duration;

use turnprint_ipc::server::{self, FrameVerifier, ServerConfig};
use turnprint_verifier::{OrbVerifier, VerifierParams};

const USAGE: &str = "usage: turnprint-verifier --prefix NAME [--max-memory-mb N] \
                     [--heartbeat-ms N] [--report-secs N]";

/// Parsed command line.
struct Args {
    server: ServerConfig,
}

fn parse_args(mut it: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut server = ServerConfig::new("default");
    let mut prefix = None;
    while let Some(flag) = it.next() {
        if flag == "-h" || flag == "--help" {
            return Err(USAGE.to_string());
        }
        let mut value = || {
            it.next()
                .ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))
        };
        let number = |v: String| {
            v.parse::<u64>()
                .map_err(|_| format!("{flag}: {v:?} is not a whole number\n{USAGE}"))
        };
        match flag.as_str() {
            "--prefix" => prefix = Some(value()?),
            "--max-memory-mb" => {
                let mb = number(value()?)?;
                if mb == 0 {
                    return Err(format!("--max-memory-mb must be at least 1\n{USAGE}"));
                }
                server.max_memory_bytes = (mb as usize) << 20;
            }
            "--heartbeat-ms" => {
                let ms = number(value()?)?;
                if ms == 0 {
                    return Err(format!("--heartbeat-ms must be at least 1\n{USAGE}"));
                }
                server.heartbeat_period = Duration::from_millis(ms);
            }
            "--report-secs" => {
                let s = number(value()?)?;
                server.report_period = (s > 0).then(|| Duration::from_secs(s));
            }
            other => return Err(format!("unknown argument {other:?}\n{USAGE}")),
        }
    }
    server.prefix = prefix.ok_or_else(|| format!("--prefix is required\n{USAGE}"))?;
    Ok(Args { server })
}

/// The vision code behind the loop: ORB features kept under the same memory
/// cap the loop enforces (least recently used keyframes go first).
fn vision_verifier(args: &Args) -> Result<Box<dyn FrameVerifier>, String> {
    let params = VerifierParams {
        memory_cap: args.server.max_memory_bytes,
        ..VerifierParams::default()
    };
    Ok(Box::new(OrbVerifier::new(params)?))
}

fn main() -> ExitCode {
    // iceoryx2 warns about its missing optional config file on every start;
    // only its errors matter here (IOX2_LOG_LEVEL overrides).
    iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    let args = match parse_args(std::env::args().skip(1)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let mut verifier = match vision_verifier(&args) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("turnprint-verifier: {e}");
            return ExitCode::from(2);
        }
    };
    match server::run(&args.server, &mut *verifier) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("turnprint-verifier: {e}");
            ExitCode::FAILURE
        }
    }
}
