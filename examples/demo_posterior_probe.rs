use rand::SeedableRng;
use slipbayes::model::{ModelSpec, Posterior};
use slipbayes::sampler::*;
use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let walkers: usize = args.get(1).map_or(56, |s| s.parse().unwrap());
    let steps: u64 = args.get(2).map_or(600, |s| s.parse().unwrap());
    let spec = ModelSpec::load(std::path::Path::new("models/demo.toml")).unwrap();
    let post = Posterior::new(&spec).unwrap();
    let t = Instant::now();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let start = initial_around_optimum(&post, post.start(), walkers, 4, &mut rng).unwrap();
    println!("optimum after {} evals in {:?}: lp {} pd {}", start.optimum.evaluations, t.elapsed(), start.optimum.log_density, start.optimum.positive_definite);
    for (n, v) in post.param_names().iter().zip(&start.optimum.x) { println!("{n} = {:.4e}", v.exp()); }
    let config = SamplerConfig::new(walkers, 4, 1).unwrap().with_moves(vec![(Move::stretch(), 0.5), (Move::differential_evolution(), 0.5)]).unwrap();
    let mut s = EnsembleSampler::new(&post, config, start.walkers).unwrap();
    let t = Instant::now();
    let rep = s.run(Steps::Fixed(steps), &mut NullSink, &mut Silent).unwrap();
    println!("run {:?}: acc {:.3} tau {:?} conv {} problems {:?}", t.elapsed(), rep.mean_acceptance(), rep.tau.as_ref().map(|t| (t.max, t.min, t.reliable)), rep.converged, rep.problems);
    if let Some(r) = &rep.rhat { println!("rhat max {:?}", r.iter().cloned().fold(0.0, f64::max)); }
}
