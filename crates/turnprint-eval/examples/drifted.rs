//! Writes a KITTI ground-truth file through the evaluation's strong drift
//! model (`eval::drift::DriftModel::strong`: heading random walk 0.4°/√m,
//! log-scale random walk 0.001/√m) as a TUM file, one pose per frame at
//! 10 Hz, to test the online detector and the verifier on a drifting map.
//!
//! Usage: `cargo run --release --example drifted -- GT.txt SEED OUT.tum [FACTOR]`
//! (`FACTOR` scales both random walks, default 1).

use std::io::Write;
use std::path::Path;

use rand::SeedableRng;
use turnprint::io::{read_trajectory, Format};
use turnprint_eval::drift::DriftModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (gt, seed, out, factor) = match args.as_slice() {
        [gt, seed, out] => (gt, seed, out, 1.0),
        [gt, seed, out, factor] => (gt, seed, out, factor.parse()?),
        _ => return Err("usage: drifted GT.txt SEED OUT.tum [FACTOR]".into()),
    };
    let truth = read_trajectory(Path::new(gt), Format::Kitti)?.positions();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed.parse()?);
    let drifted = DriftModel::strong().scaled(factor).apply(&truth, &mut rng);
    let mut file = std::io::BufWriter::new(std::fs::File::create(out)?);
    for (i, p) in drifted.iter().enumerate() {
        writeln!(
            file,
            "{:.6} {} {} {} 0 0 0 1",
            i as f64 * 0.1,
            p.x,
            p.y,
            p.z
        )?;
    }
    Ok(())
}
