//! The soak run's short version (`vorl soak`, [`vorl_host_sim::soak`]): a stream of generated
//! frames of every variant through one recognizer, each frame held against a fresh
//! recognizer, resident memory sampled. The long run (100 000 frames) is
//! `scripts/soak.sh` (docs/reliability.md, "Soak run").

use vorl_host_sim::gen::Variant;
use vorl_host_sim::soak::{run, SoakOptions};

#[test]
fn soak_short_one_recognizer_matches_fresh_ones_and_memory_stays_flat() {
    let opts = SoakOptions {
        frames: 280,
        distinct: 28,
        reuse: 10,
        seed: 11,
        width: 640,
        height: 480,
        sample_every: 40,
    };
    let r = run(&opts, |line| eprintln!("{line}")).unwrap();
    eprintln!("{r:?}");
    assert_eq!(r.frames, 280);
    assert_eq!(r.rendered, 28, "each rendered frame goes through {} times", opts.reuse);
    // Every variant is in the stream, and two with the platform estimated as well.
    assert_eq!(r.sources.len(), Variant::ALL.len() + 2);
    assert_eq!(r.errors, 0, "{:?}", r.first_problem);
    assert_eq!(r.mismatches, 0, "{:?}", r.first_problem);
    // Frames hold 2–5 parts; most of them are taught.
    assert!(r.detections >= 2 * r.frames, "{} detections", r.detections);
    assert!(r.known * 2 > r.detections, "{} of {} known", r.known, r.detections);
    // Flat memory: nothing kept per frame. A leak of one 640×480 plane per frame would add
    // 300 KiB a frame, 72 MiB over the samples.
    assert_eq!(r.memory.len(), 7);
    let (first, last) = (r.first_rss_kib(), r.final_rss_kib());
    assert!(first > 0, "no /proc/self/status?");
    assert!(
        last <= first + 8 * 1024,
        "resident memory grew from {first} KiB to {last} KiB over {} frames",
        r.frames - r.memory[0].frames
    );
}
