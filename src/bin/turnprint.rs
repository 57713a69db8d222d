//! The `turnprint` command line: see `cli.md` for the contract.

fn main() {
    eprintln!("turnprint: no command yet");
    std::process::exit(2);
}
