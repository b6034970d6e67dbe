use decompose::solver::*;
fn main() {
    if std::env::var("SEQ").is_ok() { faer::set_global_parallelism(faer::Par::Seq); }
    for n in [1000usize, 7680, 30000] {
    let mut sys = LinearSystem::new(n);
    let w = 96;
    for i in 0..n { if i % w + 1 < w && i+1<n { sys.add(&[(i,1.0),(i+1,-1.0)],0.1,1.0);} if i + w < n { sys.add(&[(i,1.0),(i+w,-1.0)],0.0,1.0);} }
    sys.add(&[(0,1.0)],0.0,1.0);
    let t = std::time::Instant::now();
    let (_, info) = sys.solve(&SolverParams::default()).unwrap();
    println!("{n} {:?} {:?}", t.elapsed(), info.iterations);
    }
}
