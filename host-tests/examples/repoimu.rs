//! Score filters on the RepoIMU recordings (development aid): `cargo run --release -p host-tests
//! --example repoimu -- [filter] [config.toml]`.
use host_tests::config::parse_config;
use host_tests::real::{score, RepoImu};
use host_tests::replay::FilterKind;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter = args.first().and_then(|s| FilterKind::from_name(s)).unwrap_or(FilterKind::Ekf);
    let mut cfg = RepoImu::config();
    if let Some(p) = args.get(1) {
        let lever = cfg.conditioning.lever_arm;
        cfg = parse_config(&std::fs::read_to_string(p).unwrap()).unwrap();
        cfg.conditioning.lever_arm = lever;
    }
    let files = RepoImu::load(&RepoImu::dir()).unwrap();
    let (mut si, mut sh) = (0.0, 0.0);
    for (name, rows) in &files {
        let r = score(rows, filter, &cfg).unwrap();
        println!("{name:40} incl {:6.2} heading {:6.2}", r.inclination_deg, r.heading_deg);
        si += r.inclination_deg;
        sh += r.heading_deg;
    }
    let n = files.len() as f64;
    println!("mean {:34} incl {:6.2} heading {:6.2}", filter.name(), si / n, sh / n);
}
