//! Times `squish deform`'s frame (`deform_pair`) on two mesh files, for the Python overhead
//! measurement of docs/python.md: `cargo run --release -p squish-shot --example deform_timing --
//! A B ROUNDS` prints the median time of a round in milliseconds (each round a fresh deformer, as
//! one `squish.deform` call).

use std::path::PathBuf;
use std::time::Instant;

use squish::pipeline::Deformer;
use squish_shot::two_objects::{PairParameters, deform_pair};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [a, b, rounds] = args.as_slice() else {
        return Err("usage: deform_timing A B ROUNDS".into());
    };
    let meshes = [squish_io::read_mesh(&PathBuf::from(a))?, squish_io::read_mesh(&PathBuf::from(b))?];
    let settings = PairParameters::default();
    let mut times = Vec::new();
    for _ in 0..rounds.parse::<usize>()? {
        let start = Instant::now();
        let deformed = deform_pair(["a", "b"], [&meshes[0], &meshes[1]], &settings, &mut Deformer::new())
            .map_err(|e| e.to_string())?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(deformed);
    }
    times.sort_by(f64::total_cmp);
    println!("{:.3}", times[times.len() / 2]);
    Ok(())
}
