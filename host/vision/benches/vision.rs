//! Per-frame cost of the vision pipeline (issue 4's target: ≤ 2 ms per 640 × 480 frame on one
//! core) and of the synthetic microscope the firmware simulator's camera uses.
//! `cargo bench -p mesopush-vision --bench vision`

use criterion::{Criterion, criterion_group, criterion_main};
use mesopush_core::geom::Pose;
use mesopush_vision::demo::demo_sequence_frame;
use mesopush_vision::{
    DemoFixture, RenderSettings, Renderer, Scene, TrackSettings, Tracker, paper_peg,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let walls = DemoFixture::default().walls().unwrap();
    let peg = paper_peg();
    let settings = RenderSettings::default();
    let needle = settings.needle;
    let mut renderer = Renderer::new(settings, &walls).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let empty = Scene { walls: &walls, peg: None, peg_pose: Pose::default(), probe_tip: None };
    let bg = renderer.render_averaged(&empty, 16, &mut rng).image;
    let (pose, tip) = demo_sequence_frame(&peg, &needle, 10, 30);
    let scene = Scene { peg: Some(&peg), peg_pose: pose, probe_tip: Some(tip), ..empty };
    let frame = renderer.render(&scene, &mut rng).image;
    let mut tracker = Tracker::new(&bg, TrackSettings::default()).unwrap();
    assert!(tracker.measure(&frame).unwrap().flags.is_empty());
    c.bench_function("track_640x480_peg_and_probe", |b| {
        b.iter(|| tracker.measure(black_box(&frame)).unwrap())
    });
    c.bench_function("render_640x480_peg_and_probe", |b| {
        b.iter(|| renderer.render(black_box(&scene), &mut rng))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
