//! Real data for the library's unit tests: where the shared data folder
//! holds a file, the same places `turnprint_eval::data::require` looks.

/// `rel` (e.g. `kitti_gt/00.txt`) where `turnprint_eval::data::require`
/// finds it (unit tests cannot use it): in `$TURNPRINT_DATA` alone when
/// set, else in `../shared/data` beside the repository, then in the
/// set-up cache `target/data`; `None` after a `skipped:` line (a failure
/// under `CI=true`).
pub(crate) fn shared_data(rel: &str) -> Option<std::path::PathBuf> {
    let dirs: Vec<std::path::PathBuf> = match std::env::var_os("TURNPRINT_DATA") {
        Some(dir) => vec![dir.into()],
        None => vec![
            concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data").into(),
            concat!(env!("CARGO_MANIFEST_DIR"), "/target/data").into(),
        ],
    };
    let found = dirs.iter().map(|d| d.join(rel)).find(|p| p.is_file());
    if found.is_none() {
        let message = format!("{rel} is in none of {dirs:?} (set TURNPRINT_DATA)");
        let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
        assert!(!ci, "CI=true: {message}");
        eprintln!("skipped: {message}");
    }
    found
}
