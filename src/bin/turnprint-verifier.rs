//! The visual verifier sidecar.

fn main() {
    eprintln!("turnprint-verifier: not built yet");
    std::process::exit(2);
}
