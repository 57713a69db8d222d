//! The `turnprint` command line. The contract (`match`, `loops`, `merge`,
//! `stream`, their JSON) is `cli.md`; everything else here is ours.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;
use turnprint::geometry::Similarity3;
use turnprint::io::{write_tum, Format};
use turnprint::pipeline::{self, PreparedPath};
use turnprint::{Config, Hypothesis, Trajectory};

#[derive(Parser)]
#[command(
    name = "turnprint",
    version,
    about = "Find where robot paths overlap by the shape of their turns \
             (no scale, frame or direction needed)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// ROS 2 bags (`.mcap`, `--format mcap`): the topic to read
    /// (nav_msgs/Odometry, geometry_msgs/PoseStamped or
    /// PoseWithCovarianceStamped); default: the bag's only pose topic.
    #[arg(long, global = true, value_name = "NAME")]
    topic: Option<String>,
}

/// `--topic`, set once from the command line before any input is read.
static TOPIC: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();

#[derive(Subcommand)]
enum Command {
    /// Where path B overlaps path A, and the similarity mapping B into A.
    Match {
        /// Path A (the reference frame); `-` reads it from stdin.
        a: PathBuf,
        /// Path B; `-` reads it from stdin.
        b: PathBuf,
        /// Print one JSON object (cli.md) instead of a table.
        #[arg(long)]
        json: bool,
        /// Hypotheses to report.
        #[arg(long, default_value_t = 5)]
        top: usize,
        /// Input format of both files (auto, tum, kitti, euroc, xyz, gpx, csv, mcap).
        #[arg(long, default_value = "auto")]
        format: Format,
        /// Input format of B, when it differs from A's.
        #[arg(long)]
        format_b: Option<Format>,
    },
    /// Places that path A revisits (loop-closure hypotheses).
    Loops {
        /// The path; `-` reads it from stdin.
        a: PathBuf,
        /// Print one JSON object (cli.md) instead of a table.
        #[arg(long)]
        json: bool,
        /// Loops to report.
        #[arg(long, default_value_t = 10)]
        top: usize,
        /// Input format (auto, tum, kitti, euroc, xyz, gpx, csv, mcap).
        #[arg(long, default_value = "auto")]
        format: Format,
        /// Turn the within-map drift prior off (shape and geometry only).
        #[arg(long)]
        no_prior: bool,
        /// Leave out loops scoring below this (0..1): 0.1 gives a short,
        /// precise list (EVALUATION.md has the trade-off).
        #[arg(long, default_value_t = 0.0, value_parser = score_in_unit_interval)]
        min_score: f64,
        /// Also draw the path and its loops (SVG or PNG by extension).
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Corrects A's drift with its loops (pose graph) and writes it as TUM.
    Correct {
        /// The path; `-` reads it from stdin.
        a: PathBuf,
        /// Output TUM file: one pose per pose of A, in A's order and frame.
        #[arg(short, long)]
        output: PathBuf,
        /// Print one JSON object (cli.md) with the loops kept and rejected;
        /// also the graph's `group`, the `bias` taken out of the odometry
        /// (a turn and a scale growth the same all along: `turn_degrees`
        /// and `scale` over the whole path, or null), and per loop
        /// `reversed`, `residual` (sigmas after the solve), `scale`,
        /// `scale_shown` (whether the
        /// passes' shape fixes that scale: only those count for `auto`) and
        /// `height` (how far apart in height its passes lay before the
        /// final solve levelled them: the odometry's height drift there).
        #[arg(long)]
        json: bool,
        /// Take the loops from this file (the object `loops --json` prints)
        /// instead of searching for them.
        #[arg(long)]
        loops: Option<PathBuf>,
        /// Also write the graph before optimisation in g2o's text format.
        #[arg(long)]
        g2o: Option<PathBuf>,
        /// Also draw the path before and after, with the loops kept and
        /// rejected (SVG or PNG by extension).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Input format (auto, tum, kitti, euroc, xyz, gpx, csv, mcap).
        #[arg(long, default_value = "auto")]
        format: Format,
        /// Node group: auto (Sim3 when loops whose shape fixes a scale show it drifting), se3 (metric odometry: LiDAR, stereo, VIO, wheels) or sim3 (monocular: its loops often fix no scale)
        #[arg(long, default_value = "auto", value_parser = group)]
        group: turnprint::correct::Group,
    },
    /// Writes the paths placed in the first one's frame as one TUM file: two
    /// by their best hypothesis, more each through the overlaps that place it.
    Merge {
        /// The paths, the first the reference frame; `-` reads one from stdin.
        #[arg(required = true, num_args = 2..)]
        paths: Vec<PathBuf>,
        /// Output TUM file.
        #[arg(short, long)]
        output: PathBuf,
        /// Print one JSON object (cli.md): each path's similarity into the
        /// first one's frame, or that it was not merged.
        #[arg(long)]
        json: bool,
        /// Also draw the paths in the first one's frame and the common
        /// parts that placed them (SVG or PNG by extension).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Input format of the files.
        #[arg(long, default_value = "auto")]
        format: Format,
        /// Input format of the second path, when it differs (two paths).
        #[arg(long)]
        format_b: Option<Format>,
        /// Write nothing and fail when the best hypothesis scores below this
        /// (0..1; two paths); 0 merges whatever ranks first.
        #[arg(long, default_value_t = 0.0, value_parser = score_in_unit_interval)]
        min_score: f64,
    },
    /// Replays A one pose at a time through the online detector (JSON Lines).
    Stream {
        /// Keep a drift-corrected path up to date as loops arrive (a
        /// `corrected` event per re-optimisation, with the loops kept and
        /// the `bias` taken out of the odometry, as `correct --json`'s) and
        /// write it here as TUM
        /// at the end, corrected with every loop from scratch (the same
        /// however the re-optimisations fell); with --verify only confirmed
        /// loops enter.
        #[arg(long, value_name = "OUT")]
        correct: Option<PathBuf>,
        /// The path; `-` reads poses from stdin as they arrive (a pipe from
        /// a running odometry process) and writes each event at once.
        a: PathBuf,
        /// JSON Lines on stdout (the only output form).
        #[arg(long)]
        json: bool,
        /// Candidates per finalised segment.
        #[arg(long, default_value_t = 3)]
        top: usize,
        /// Input format (auto, tum, kitti, euroc, xyz, gpx, csv, mcap).
        #[arg(long, default_value = "auto")]
        format: Format,
        /// Start the visual verifier sidecar and verify every candidate on
        /// keyframes rendered in the built-in test world.
        #[arg(long)]
        verify: bool,
        /// The true poses the keyframes are rendered from (paired with A by
        /// timestamp, else by order); default: A itself.
        #[arg(long, requires = "verify")]
        truth: Option<PathBuf>,
        /// Camera types assigned along the path.
        #[arg(long, default_value = "pinhole,fisheye,omni", requires = "verify")]
        cameras: String,
        /// With --verify: a figure (SVG or PNG) of the path and the longest
        /// confirmed loop.
        #[arg(long, requires = "verify")]
        plot: Option<PathBuf>,
        /// Turn off the drifting-map probe (on by default: where nothing is
        /// near, it probes with a radius growing with the path in between,
        /// and places the newest stretch on the whole road network, for
        /// strongly drifting odometry; on a consistent map its candidates
        /// are other roads: EVALUATION_ONLINE.md).
        #[arg(long)]
        no_drift_probe: bool,
        /// Matching threads, 1 to 64, over one history (the same candidates
        /// and memory with any number). Default: 2 where the machine has a
        /// second core, else 1.
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..=turnprint::online::OnlineConfig::MAX_WORKERS as i64))]
        workers: Option<u16>,
        /// Live map merging: this robot's segments shared with the fleet's
        /// other robots over Zenoh (key expressions `turnprint/NAME/`),
        /// theirs matched against its own.
        #[arg(long, value_name = "NAME", requires = "robot")]
        fleet: Option<String>,
        /// This robot's name in the fleet.
        #[arg(long, value_name = "ID", requires = "fleet")]
        robot: Option<String>,
        /// A Zenoh endpoint to listen on (`tcp/127.0.0.1:7447`); repeatable.
        #[arg(long, value_name = "EP", requires = "fleet")]
        listen: Vec<String>,
        /// A Zenoh endpoint to connect to; repeatable. With neither
        /// --listen nor --connect, Zenoh's default discovery is used.
        #[arg(long, value_name = "EP", requires = "fleet")]
        connect: Vec<String>,
        /// Replay A at this many poses per second (default: as fast as it
        /// can).
        #[arg(long, value_name = "HZ", requires = "fleet", value_parser = positive_seconds)]
        rate: Option<f64>,
        /// Keep matching and listening this many seconds after A's last
        /// pose before the summary.
        #[arg(long, value_name = "S", requires = "fleet", default_value_t = 0.0, value_parser = non_negative_seconds)]
        linger: f64,
        /// With --fleet --verify: the path the test world is built along,
        /// one for the whole fleet; default: this robot's truth.
        #[arg(long, value_name = "PATH", requires_all = ["verify", "fleet"])]
        world: Option<PathBuf>,
    },
}

/// A positive finite number (a rate).
fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a positive number")),
    }
}

/// A finite number, 0 or more (seconds).
fn non_negative_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a number of seconds (0 or more)")),
    }
}

/// A score threshold: a number in [0, 1] (scores are in [0, 1]; NaN or a
/// value outside would silently keep everything or nothing).
fn score_in_unit_interval(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a score between 0 and 1")),
    }
}

/// A node group by name.
fn group(s: &str) -> Result<turnprint::correct::Group, String> {
    s.parse()
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let _ = TOPIC.set(cli.topic.clone());
    let result = match cli.command {
        Command::Match {
            a,
            b,
            json,
            top,
            format,
            format_b,
        } => run_match(&a, &b, json, top, format, format_b.unwrap_or(format)),
        Command::Loops {
            a,
            json,
            top,
            format,
            no_prior,
            min_score,
            plot,
        } => run_loops(
            &a,
            json,
            top,
            format,
            (no_prior, min_score),
            plot.as_deref(),
        ),
        Command::Correct {
            a,
            output,
            json,
            loops,
            g2o,
            plot,
            format,
            group,
        } => run_correct(
            &a,
            &output,
            json,
            (loops.as_deref(), g2o.as_deref(), plot.as_deref()),
            format,
            group,
        ),
        Command::Merge {
            paths,
            output,
            json,
            plot,
            format,
            format_b,
            min_score,
        } => match paths.as_slice() {
            [a, b] => run_merge(
                a,
                b,
                &output,
                json,
                plot.as_deref(),
                (format, format_b.unwrap_or(format)),
                min_score,
            ),
            _ => run_merge_many(&paths, &output, json, plot.as_deref(), format, min_score),
        },
        Command::Stream {
            a,
            json,
            top,
            format,
            verify,
            truth,
            cameras,
            plot,
            no_drift_probe,
            workers,
            correct,
            fleet,
            robot,
            listen,
            connect,
            rate,
            linger,
            world,
        } => {
            let config = turnprint::online::OnlineConfig {
                top_k: top,
                drift_probe: !no_drift_probe,
                // A replay wants throughput: a second matching thread where
                // there is a second core (the same candidates either way).
                workers: workers.map_or_else(
                    || std::thread::available_parallelism().map_or(1, |n| n.get().min(2)),
                    usize::from,
                ),
                ..Default::default()
            };
            let fleet = fleet
                .zip(robot)
                .map(|(fleet, robot)| turnprint_fleet::Options {
                    fleet,
                    robot,
                    endpoints: turnprint_fleet::Endpoints { listen, connect },
                    rate,
                    linger,
                });
            if let Some(options) = fleet {
                if correct.is_some() || plot.is_some() || a == Path::new("-") {
                    Err("stream --fleet replays a file: give it a path, without --correct or --plot".into())
                } else {
                    let files = verify.then_some(turnprint_cli::fleet_verify::Files {
                        truth,
                        world,
                        cameras,
                    });
                    run_stream_fleet(&a, &config, format, &options, files)
                }
            } else if verify && a == Path::new("-") {
                Err(
                    "stream --verify renders keyframes along the whole path: give it a file, \
                     not stdin (-)"
                        .into(),
                )
            } else if verify {
                let files = VerifyFiles {
                    truth,
                    plot,
                    correct,
                };
                run_stream_verified(&a, &config, format, files, &cameras, json)
            } else {
                run_stream(&a, &config, format, correct.as_deref())
            }
        }
    };
    match result {
        Ok(()) | Err(Failure::StdoutClosed) => ExitCode::SUCCESS,
        Err(Failure::Message(message)) => {
            eprintln!("turnprint: {message}");
            ExitCode::FAILURE
        }
    }
}

/// Why a command stopped.
enum Failure {
    /// One clear line for stderr.
    Message(String),
    /// The reader of stdout stopped reading (`| head`): what it read is
    /// complete, so this is no error (and never a panic).
    StdoutClosed,
}

impl From<String> for Failure {
    fn from(message: String) -> Self {
        Failure::Message(message)
    }
}

impl From<&str> for Failure {
    fn from(message: &str) -> Self {
        Failure::Message(message.to_string())
    }
}

impl From<std::io::Error> for Failure {
    /// A failed write to stdout.
    fn from(e: std::io::Error) -> Self {
        match e.kind() {
            std::io::ErrorKind::BrokenPipe => Failure::StdoutClosed,
            _ => Failure::Message(format!("<stdout>: {e}")),
        }
    }
}

impl From<turnprint::Error> for Failure {
    fn from(e: turnprint::Error) -> Self {
        match e {
            turnprint::Error::Io { source, .. }
                if source.kind() == std::io::ErrorKind::BrokenPipe =>
            {
                Failure::StdoutClosed
            }
            e => Failure::Message(e.to_string()),
        }
    }
}

/// A spinner on stderr naming the running stage, only when stderr is a
/// terminal (scripts and CI get clean output).
struct Progress(ProgressBar);

impl Progress {
    fn new() -> Self {
        let bar = if std::io::stderr().is_terminal() {
            let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
            bar.set_style(
                ProgressStyle::with_template("{spinner} {msg} {elapsed}").expect("valid template"),
            );
            bar.enable_steady_tick(Duration::from_millis(100));
            bar
        } else {
            ProgressBar::hidden()
        };
        Progress(bar)
    }

    fn stage(&self, message: &str) {
        self.0.set_message(message.to_string());
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// The trajectory in `path`, or on stdin for `-` (`--topic` for bags).
fn read(path: &Path, format: Format) -> Result<Trajectory, String> {
    let topic = TOPIC.get().and_then(|t| t.as_deref());
    turnprint_cli::input::read(path, format, topic).map_err(|e| e.to_string())
}

fn prepare(t: &Trajectory, config: &Config) -> Result<PreparedPath, String> {
    PreparedPath::new(t, config).map_err(|e| e.to_string())
}

/// Reads A and B and matches them, with a progress spinner.
fn match_files(
    a: &Path,
    b: &Path,
    fa: Format,
    fb: Format,
    config: &Config,
) -> Result<(Trajectory, Trajectory, Vec<Hypothesis>), String> {
    if a == Path::new("-") && b == Path::new("-") {
        return Err("A and B cannot both be stdin (-)".into());
    }
    let progress = Progress::new();
    progress.stage("reading");
    let (ta, tb) = (read(a, fa)?, read(b, fb)?);
    progress.stage("preparing (plane, track, signature, segments)");
    let (pa, pb) = (prepare(&ta, config)?, prepare(&tb, config)?);
    progress.stage("matching");
    let hypotheses = pipeline::match_across_rates(&ta, &tb, &pa, &pb, config);
    Ok((ta, tb, hypotheses))
}

fn run_match(
    a: &Path,
    b: &Path,
    json: bool,
    top: usize,
    fa: Format,
    fb: Format,
) -> Result<(), Failure> {
    let config = Config {
        top_k: top,
        ..Config::for_matching()
    };
    let (ta, tb, hypotheses) = match_files(a, b, fa, fb, &config)?;
    if json {
        let out = json!({
            "a": {"path": a.display().to_string(), "poses": ta.len()},
            "b": {"path": b.display().to_string(), "poses": tb.len()},
            "hypotheses": hypotheses.iter().map(Hypothesis::to_json).collect::<Vec<_>>(),
        });
        print_json(&out)
    } else {
        writeln!(
            std::io::stdout(),
            "A: {} ({} poses)   B: {} ({} poses)",
            a.display(),
            ta.len(),
            b.display(),
            tb.len()
        )?;
        print_table(&hypotheses, "A range", "B range")
    }
}

fn run_loops(
    a: &Path,
    json: bool,
    top: usize,
    fa: Format,
    (no_prior, min_score): (bool, f64),
    plot: Option<&Path>,
) -> Result<(), Failure> {
    let progress = Progress::new();
    progress.stage("reading");
    let ta = read(a, fa)?;
    let mut config = Config {
        top_k: top,
        ..Config::for_loops()
    };
    if no_prior {
        config.drift_prior = None;
    }
    config.min_score = min_score;
    progress.stage("preparing (plane, track, signature, segments)");
    let pa = prepare(&ta, &config)?;
    progress.stage("searching loops");
    let loops = pipeline::find_loops_prepared(&pa, &config);
    drop(progress);
    if let Some(fig) = plot {
        turnprint_cli::plot::plot_loops(fig, &ta.positions(), &loops).map_err(|e| e.to_string())?;
        eprintln!("figure of {} loops in {}", loops.len(), fig.display());
    }
    if json {
        let entries: Vec<serde_json::Value> = loops
            .iter()
            .map(|h| {
                let j = h.to_json();
                json!({
                    "rank": j.rank, "score": j.score, "zncc": j.zncc, "reversed": j.reversed,
                    "query_range": j.a_range, "match_range": j.b_range,
                    "scale": j.scale, "rotation": j.rotation, "translation": j.translation,
                    "rmse": j.rmse, "turning_deg": j.turning_deg,
                })
            })
            .collect();
        let out = json!({"path": a.display().to_string(), "poses": ta.len(), "loops": entries});
        print_json(&out)
    } else {
        writeln!(std::io::stdout(), "{} ({} poses)", a.display(), ta.len())?;
        print_table(&loops, "query", "match")
    }
}

fn run_correct(
    a: &Path,
    output: &Path,
    json: bool,
    (loops_file, g2o, plot): (Option<&Path>, Option<&Path>, Option<&Path>),
    format: Format,
    group: turnprint::correct::Group,
) -> Result<(), Failure> {
    use turnprint::correct::{self, CorrectConfig, LoopClosure};
    let started = std::time::Instant::now();
    let progress = Progress::new();
    progress.stage("reading");
    let ta = read(a, format)?;
    let config = CorrectConfig {
        group,
        ..CorrectConfig::default()
    };
    let loops = match loops_file {
        Some(file) => {
            let text =
                std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
            LoopClosure::from_json(&ta, &text, &file.display().to_string())
                .map_err(|e| e.to_string())?
        }
        None => {
            progress.stage("preparing (plane, track, signature, segments)");
            let pa = prepare(&ta, &config.loops)?;
            progress.stage("searching loops");
            pipeline::find_loops_prepared(&pa, &config.loops)
                .iter()
                .map(|h| LoopClosure::from_hypothesis(&ta, h))
                .collect::<turnprint::Result<Vec<_>>>()
                .map_err(|e| e.to_string())?
        }
    };
    progress.stage("optimising the pose graph");
    let corrected = correct::correct_with_loops(&ta, &loops, &config).map_err(|e| e.to_string())?;
    drop(progress);
    let out = corrected.trajectory(output.display().to_string());
    write_tum(output, &out).map_err(|e| e.to_string())?;
    if let Some(file) = g2o {
        std::fs::write(file, correct::g2o::to_g2o(&corrected.graph))
            .map_err(|e| format!("{}: {e}", file.display()))?;
    }
    if let Some(fig) = plot {
        let marks: Vec<_> = corrected
            .loops
            .iter()
            .map(|l| (l.closure.query_range, l.closure.match_range, l.kept))
            .collect();
        turnprint_cli::plot::plot_correction(fig, &ta.positions(), &out.positions(), &marks)
            .map_err(|e| e.to_string())?;
    }
    let kept = corrected.kept();
    let seconds = started.elapsed().as_secs_f64();
    if json {
        let entries: Vec<serde_json::Value> = corrected
            .loops
            .iter()
            .map(|l| {
                let c = &l.closure;
                json!({
                    "query_range": c.query_range, "match_range": c.match_range,
                    "score": c.score, "reversed": c.reversed, "kept": l.kept,
                    "residual": if l.residual.is_finite() { json!(l.residual) } else { json!(null) },
                    "scale": c.query_T_match.scale, "scale_shown": c.scale_shown,
                    "height": c.height(),
                })
            })
            .collect();
        let out = json!({
            "path": a.display().to_string(), "poses": ta.len(),
            "group": corrected.group.name(),
            "bias": corrected.bias.map(|b| b.to_json()),
            "kept": kept, "rejected": corrected.loops.len() - kept,
            "loops": entries, "seconds": seconds,
        });
        print_json(&out)
    } else {
        // The bias taken out, in the words of `correct --json`'s fields.
        // An SE(3) graph measures no scale growth: only the turn is named.
        let bias = corrected.bias.map_or(String::new(), |b| {
            let scale = if b.log_scale == 0.0 {
                String::new()
            } else {
                format!(" and a scale of {:.3}", b.log_scale.exp())
            };
            format!(
                ", a turn of {:.1}°{scale} over the path taken out",
                b.turn.to_degrees()
            )
        });
        writeln!(
            std::io::stdout(),
            "{} ({} poses): {} loops kept, {} rejected ({} graph{bias}, {:.2} s); corrected path in {}",
            a.display(),
            ta.len(),
            kept,
            corrected.loops.len() - kept,
            corrected.group.name(),
            seconds,
            output.display()
        )?;
        Ok(())
    }
}

/// Below this best score `merge` warns: on the KITTI evaluation (seed 1),
/// 124 of 160 pairs with no common road rank-1 below it, and 2 of 383
/// correct merges.
const WEAK_MERGE_SCORE: f64 = 0.1;

fn run_merge(
    a: &Path,
    b: &Path,
    output: &Path,
    json: bool,
    plot: Option<&Path>,
    (fa, fb): (Format, Format),
    min_score: f64,
) -> Result<(), Failure> {
    let (ta, tb, hypotheses) = match_files(a, b, fa, fb, &Config::for_matching())?;
    let best = hypotheses.first().ok_or_else(|| {
        format!(
            "no overlap found between {} and {}",
            a.display(),
            b.display()
        )
    })?;
    if best.score < min_score {
        return Err(format!(
            "best overlap of {} and {} scores {:.3}, below --min-score {}: nothing written",
            a.display(),
            b.display(),
            best.score,
            min_score
        )
        .into());
    }
    let merged = pipeline::merge(&ta, &tb, best);
    write_tum(output, &merged).map_err(|e| e.to_string())?;
    if let Some(fig) = plot {
        let a_points = ta.positions();
        let b_in_a: Vec<_> = tb.positions().iter().map(|p| best.transform(p)).collect();
        turnprint_cli::plot::plot_merge(fig, &a_points, &b_in_a, best)
            .map_err(|e| e.to_string())?;
    }
    eprintln!(
        "merged {} + {} poses into {} (score {:.3}, scale {:.4}, rmse {:.3}{})",
        ta.len(),
        tb.len(),
        output.display(),
        best.score,
        best.scale,
        best.rmse,
        plot.map_or(String::new(), |p| format!(", figure {}", p.display()))
    );
    if best.score < WEAK_MERGE_SCORE {
        eprintln!(
            "warning: score {:.3} is weak: most paths with no common road score below \
             {WEAK_MERGE_SCORE} (EVALUATION.md); check the figure, or refuse with --min-score",
            best.score
        );
    }
    if json {
        let frames = [Some(Similarity3::identity()), Some(best.similarity())];
        print_json(&placement_json(
            &[a, b],
            &[&ta, &tb],
            &frames,
            &[None, Some(0)],
        ))?;
    }
    Ok(())
}

/// `merge` of more than two paths: each placed in the first one's frame
/// through the overlaps that place it ([`pipeline::merge_many`]).
fn run_merge_many(
    paths: &[PathBuf],
    output: &Path,
    json: bool,
    plot: Option<&Path>,
    format: Format,
    min_score: f64,
) -> Result<(), Failure> {
    if min_score > 0.0 {
        return Err(
            "--min-score takes two paths; with more, merge reports what it \
                    placed and through which overlap"
                .into(),
        );
    }
    if paths
        .iter()
        .filter(|p| p.as_path() == Path::new("-"))
        .count()
        > 1
    {
        return Err("at most one path can be stdin (-)".into());
    }
    let progress = Progress::new();
    progress.stage("reading");
    let trajectories = paths
        .iter()
        .map(|p| read(p, format))
        .collect::<Result<Vec<_>, _>>()?;
    progress.stage("matching every pair");
    let placement =
        pipeline::merge_many(&trajectories, &Config::for_matching()).map_err(|e| e.to_string())?;
    let placed_paths: Vec<Option<Trajectory>> = trajectories
        .iter()
        .zip(&placement.frames)
        .map(|(t, frame)| frame.as_ref().map(|f| pipeline::merge::placed(t, f)))
        .collect();
    let mut poses = Vec::new();
    for t in placed_paths.iter().flatten() {
        poses.extend(t.poses.iter().cloned());
    }
    let merged = Trajectory {
        source: "merged".into(),
        poses,
    };
    write_tum(output, &merged).map_err(|e| e.to_string())?;
    if let Some(fig) = plot {
        let positions: Vec<_> = placed_paths
            .iter()
            .map(|t| t.as_ref().map(Trajectory::positions))
            .collect();
        let overlaps: Vec<_> = placement
            .used
            .iter()
            .map(|o| (o.a, o.b, o.hypothesis.a_range, o.hypothesis.b_range))
            .collect();
        turnprint_cli::plot::plot_placement(fig, &positions, &overlaps)
            .map_err(|e| e.to_string())?;
    }
    let placed = placement.frames.iter().filter(|f| f.is_some()).count();
    eprintln!(
        "placed {placed} of {} paths in the frame of {} ({} poses into {}{}); overlaps used {}, \
         contradicted {}",
        paths.len(),
        paths[0].display(),
        merged.len(),
        output.display(),
        plot.map_or(String::new(), |p| format!(", figure {}", p.display())),
        placement.used.len(),
        placement.contradicted.len()
    );
    for (p, f) in paths.iter().zip(&placement.frames) {
        if f.is_none() {
            eprintln!(
                "not merged: {} overlaps none of the placed paths",
                p.display()
            );
        }
    }
    if json {
        let names: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
        let refs: Vec<&Trajectory> = trajectories.iter().collect();
        print_json(&placement_json(
            &names,
            &refs,
            &placement.frames,
            &placement.via,
        ))?;
    }
    Ok(())
}

/// The `merge --json` object (cli.md): per path, in input order, its
/// similarity into the first path's frame and the path it was placed
/// through, or `"merged": false`.
fn placement_json(
    names: &[&Path],
    paths: &[&Trajectory],
    frames: &[Option<Similarity3>],
    via: &[Option<usize>],
) -> serde_json::Value {
    let entries: Vec<_> = (0..names.len())
        .map(|k| {
            let (name, poses) = (names[k].display().to_string(), paths[k].len());
            match &frames[k] {
                None => json!({"path": name, "poses": poses, "merged": false}),
                Some(f) => {
                    let r = f.rotation;
                    let mut entry = json!({
                        "path": name, "poses": poses, "merged": true, "scale": f.scale,
                        "rotation": (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect::<Vec<_>>(),
                        "translation": [f.translation.x, f.translation.y, f.translation.z],
                    });
                    if let Some(v) = via[k] {
                        entry["via"] = json!(names[v].display().to_string());
                    }
                    entry
                }
            }
        })
        .collect();
    json!({ "paths": entries })
}

fn print_json(value: &serde_json::Value) -> Result<(), Failure> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer(&mut out, value).map_err(std::io::Error::from)?;
    writeln!(out)?;
    Ok(())
}

fn print_table(hypotheses: &[Hypothesis], a_name: &str, b_name: &str) -> Result<(), Failure> {
    let mut out = std::io::stdout().lock();
    if hypotheses.is_empty() {
        writeln!(out, "no overlap found")?;
        return Ok(());
    }
    writeln!(
        out,
        "{:>4} {:>6} {:>6} {:>4} {:>15} {:>15} {:>10} {:>7} {:>9} {:>7}",
        "rank", "score", "zncc", "rev", a_name, b_name, "scale", "rot°", "rmse", "turn°"
    )?;
    for h in hypotheses {
        writeln!(
            out,
            "{:>4} {:>6.3} {:>6.2} {:>4} {:>15} {:>15} {:>10.4} {:>7.1} {:>9.3} {:>7.0}",
            h.rank,
            h.score,
            h.zncc,
            if h.reversed { "yes" } else { "no" },
            format!("{}-{}", h.a_range[0], h.a_range[1]),
            format!("{}-{}", h.b_range[0], h.b_range[1]),
            h.scale,
            h.rotation_angle().to_degrees(),
            h.rmse,
            h.turning.to_degrees()
        )?;
    }
    Ok(())
}

fn run_stream(
    a: &Path,
    config: &turnprint::online::OnlineConfig,
    format: Format,
    correct: Option<&Path>,
) -> Result<(), Failure> {
    let mut out = std::io::stdout().lock();
    if a == Path::new("-") {
        let stdin = std::io::BufReader::new(std::io::stdin());
        turnprint_cli::stream::stream_lines(stdin, "<stdin>", format, config, correct, &mut out)?;
    } else {
        let trajectory = read(a, format)?;
        let name = a.display().to_string();
        turnprint_cli::stream::stream_trajectory(&trajectory, &name, config, correct, &mut out)?;
    }
    Ok(())
}

fn run_stream_fleet(
    a: &Path,
    config: &turnprint::online::OnlineConfig,
    format: Format,
    options: &turnprint_fleet::Options,
    verify: Option<turnprint_cli::fleet_verify::Files>,
) -> Result<(), Failure> {
    let topic = TOPIC.get().and_then(|t| t.as_deref());
    let mut out = std::io::stdout().lock();
    match turnprint_cli::fleet_verify::stream(a, format, topic, config, options, verify, &mut out) {
        Ok(()) => Ok(()),
        Err(turnprint_fleet::StreamError::OutputClosed) => Err(Failure::StdoutClosed),
        Err(turnprint_fleet::StreamError::Message(m)) => Err(Failure::Message(m)),
    }
}

/// The files `stream --verify` reads and writes besides the path.
struct VerifyFiles {
    /// The true poses keyframes are rendered from.
    truth: Option<PathBuf>,
    /// The figure of the longest confirmed loop.
    plot: Option<PathBuf>,
    /// The corrected path (confirmed loops only).
    correct: Option<PathBuf>,
}

fn run_stream_verified(
    a: &Path,
    config: &turnprint::online::OnlineConfig,
    format: Format,
    files: VerifyFiles,
    cameras: &str,
    json: bool,
) -> Result<(), Failure> {
    use turnprint_cli::sidecar::{stream_verified, CameraKind, VerifyOptions};
    let VerifyFiles {
        truth,
        plot,
        correct,
    } = files;
    let cameras = CameraKind::parse_list(cameras)?;
    let options = VerifyOptions {
        truth,
        cameras,
        plot,
        correct,
        topic: TOPIC.get().cloned().flatten(),
        ..VerifyOptions::default()
    };
    let mut stdout = std::io::stdout().lock();
    let mut human = HumanLines(&mut stdout, Vec::new());
    let out: &mut dyn Write = if json { &mut stdout_json() } else { &mut human };
    stream_verified(a, format, config, &options, out)?;
    Ok(())
}

/// Stdout for JSON Lines.
fn stdout_json() -> std::io::Stdout {
    std::io::stdout()
}

/// Turns the JSON Lines of `stream --verify` into one readable line per
/// decided loop (without `--json`).
struct HumanLines<'a, W: Write>(&'a mut W, Vec<u8>);

impl<W: Write> Write for HumanLines<'_, W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.1.extend_from_slice(buf);
        while let Some(end) = self.1.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.1.drain(..=end).collect();
            let Ok(v) = serde_json::from_slice::<serde_json::Value>(&line) else {
                continue;
            };
            let r = |k: &str| format!("{}-{}", v[k][0], v[k][1]);
            let text = match v["event"].as_str().unwrap_or("") {
                "verifier" => format!("verifier sidecar {} (cameras {})", if v["ready"] == true { "ready" } else { "NOT ready: candidates will expire" }, v["cameras"]),
                "candidate" => continue,
                "confirmed" => format!(
                    "CONFIRMED  loop #{:<3} poses {:>11} revisit {:>11}  {:<15} {:>4} inliers",
                    v["id"], r("query_range"), r("match_range"), v["cameras"].as_str().unwrap_or(""), v["inliers"]
                ),
                "rejected" => format!(
                    "rejected   loop #{:<3} poses {:>11} revisit {:>11}  {:<15} {}",
                    v["id"], r("query_range"), r("match_range"), v["cameras"].as_str().unwrap_or(""), v["reason"].as_str().unwrap_or("")
                ),
                "expired" => format!("expired    loop #{:<3} ({})", v["id"], v["reason"].as_str().unwrap_or("")),
                "summary" => format!(
                    "{} candidates: {} confirmed, {} rejected, {} expired; {} keyframes rendered; {:.1} s",
                    v["candidates"], v["confirmed"], v["rejected"], v["expired"], v["keyframes"], v["seconds"].as_f64().unwrap_or(0.0)
                ),
                _ => continue,
            };
            writeln!(self.0, "{text}")?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}
