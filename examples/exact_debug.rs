use ballfield::engine::{Engine, ExactEngine};
use ballfield::scenes;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = scenes::resolve(&args[1]).unwrap();
    let t_end: f64 = args[2].parse().unwrap();
    let mut e = ExactEngine::new(&scene).unwrap();
    let mut t = 0.0;
    let mut last_events = 0;
    while t < t_end {
        t += 0.01;
        e.advance_to(t);
        let s = e.stats();
        if s.events - last_events > 20000 || args.len() > 3 {
            println!("t={t:.2} events={} coll={} walls={} cross={} tc={} rests={} slides={} wakes={} hops={} fixes={} wedges={} rest_now={} sliding={}",
                s.events, s.counters.collisions, s.counters.wall_bounces, s.counters.cell_crossings, s.counters.soft_collisions,
                s.counters.rests, s.counters.slides, s.counters.wakes, s.counters.hops, s.counters.separation_fixes, s.counters.wedges, s.at_rest, s.sliding);
        }
        last_events = s.events;
    }
    if std::env::var("DUMP").is_ok() {
        println!("{}", e.world().dump());
    }
}
