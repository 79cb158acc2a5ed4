//! Cost of one evaluation of the demo posterior (`models/demo.toml`), with and without the
//! derived quantities: `cargo run --release --example posterior_cost`.
use slipbayes::density::LogDensity;
use slipbayes::model::{ModelSpec, Posterior};
fn main() {
    let spec = ModelSpec::load(std::path::Path::new("models/demo.toml")).unwrap();
    let post = Posterior::new(&spec).unwrap();
    let mut d = vec![0.0; post.derived_names().len()];
    let x = post.start().to_vec();
    let t = std::time::Instant::now();
    for _ in 0..300 {
        post.log_density(&x, &mut d).unwrap();
    }
    println!("with derived: {:?} per eval", t.elapsed() / 300);
    let t = std::time::Instant::now();
    for _ in 0..300 {
        post.log_density(&x, &mut []).unwrap();
    }
    println!("without derived: {:?} per eval", t.elapsed() / 300);
}
