//! Writing trajectories as TUM text (`t x y z qx qy qz qw`), the output
//! format of `turnprint merge`.
//!
//! Numbers are written in Rust's shortest round-trip form, so reading the
//! file back gives the same values. A pose without a timestamp gets its
//! pose index as `t` (TUM has no way to omit it); one without an
//! orientation gets the identity.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::{Error, Result, Trajectory};

/// Writes `traj` as a TUM file at `path`.
pub fn write_tum(path: &Path, traj: &Trajectory) -> Result<()> {
    let io_error = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = File::create(path).map_err(io_error)?;
    let mut w = BufWriter::new(file);
    write_tum_to(&mut w, traj).map_err(io_error)?;
    w.flush().map_err(io_error)
}

/// Writes `traj` as TUM text to `w`.
pub fn write_tum_to(mut w: impl Write, traj: &Trajectory) -> std::io::Result<()> {
    writeln!(w, "# timestamp x y z qx qy qz qw")?;
    for (i, pose) in traj.poses.iter().enumerate() {
        let t = pose.t.unwrap_or(i as f64);
        let p = &pose.position;
        let q = pose.orientation.map_or([0.0, 0.0, 0.0, 1.0], |q| {
            [q.coords.x, q.coords.y, q.coords.z, q.coords.w]
        });
        writeln!(
            w,
            "{t} {} {} {} {} {} {} {}",
            p.x, p.y, p.z, q[0], q[1], q[2], q[3]
        )?;
    }
    Ok(())
}
