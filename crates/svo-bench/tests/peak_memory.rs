//! The counting allocator measures a step's peak heap, not what was live before it.

#[global_allocator]
static ALLOC: svo_bench::peak_memory::CountingAlloc = svo_bench::peak_memory::CountingAlloc;

use svo_bench::peak_memory::{counting, measure};

#[test]
fn peak_of_a_step_is_its_own() {
    assert!(counting());
    let kept = vec![1u8; 8 << 20];
    let (sum, peak) = measure(|| {
        let a = vec![2u8; 32 << 20];
        let s: u64 = a.iter().map(|&b| u64::from(b)).sum();
        drop(a);
        let b = vec![3u8; 16 << 20];
        s + b.iter().map(|&x| u64::from(x)).sum::<u64>()
    });
    assert_eq!(sum, 2 * (32 << 20) + 3 * (16 << 20));
    let peak = peak.expect("the counting allocator is installed");
    // The 32 MiB buffer was the high point; what was live before (8 MiB) does not count.
    assert!(peak >= 32 << 20, "peak {peak}");
    assert!(peak < 40 << 20, "peak {peak} counts more than the step");
    drop(kept);
}
