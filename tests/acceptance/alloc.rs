//! No heap allocation per tick: a counting allocator (per thread, so other tests running in
//! parallel do not count) around a whole calibration flight with recording off.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

pub struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|c| c.set(c.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn allocations() -> u64 {
    ALLOCATIONS.with(|c| c.get())
}

#[test]
fn the_loop_does_not_allocate() {
    use flyarena::engine::{Arena, RunOptions};
    // every window of the station: hover average, straight flight (LS + RLS), gyro circle, spin;
    // a lossy, jittery link; telemetry
    let path = super::root().join("scenarios/yaw-offset.yaml");
    let text = std::fs::read_to_string(&path).unwrap() + "link: { jitter_ms: 3, loss: { bernoulli: 0.05 } }\n";
    let s = flyarena::scenario::Scenario::parse(&text, &path).unwrap();
    let link = s.spec().link;
    assert_eq!(link.jitter.0, 3_000_000);
    assert_eq!(link.loss, flyarena::link::LossModel::Bernoulli { p: 0.05 });
    let mut arena = Arena::new(s.spec(), RunOptions { trace: false, apply_calibration: None });
    arena.step();
    let before = allocations();
    let mut ticks = 0;
    while !arena.done() {
        arena.step();
        ticks += 1;
    }
    let during = allocations() - before;
    assert!(ticks > 50_000, "{ticks} ticks");
    assert_eq!(during, 0, "{during} allocations in {ticks} ticks");
    // the counter does count: finishing the run allocates (the report)
    let out = arena.finish();
    assert!(allocations() > before && out.vehicles[0].calibration.gyro.is_some());
}
