use nalgebra::Vector2;
use turnprint::track::{ChordParam, Smoother};
fn main() {
    for f in std::env::args().skip(1) {
        let t =
            turnprint::io::read_trajectory(std::path::Path::new(&f), turnprint::io::Format::Auto)
                .unwrap();
        let pts: Vec<Vector2<f64>> = t
            .positions()
            .iter()
            .map(|p| Vector2::new(p.x, p.y))
            .collect();
        let chord = ChordParam::new(&pts).unwrap();
        let chosen = Smoother::choose(&chord);
        println!(
            "{f}: kept {} step {:.3} chosen {:.1} steps = {:.2}",
            chord.points.len(),
            chord.typical_step,
            chosen.bandwidth / chord.typical_step,
            chosen.bandwidth
        );
    }
}
