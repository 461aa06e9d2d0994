//! Per-thread scratch arrays for the CPU tracer's per-ray lists (no allocation per
//! ray once the arrays have grown).

/// What a [`ScratchPool`] holds: arrays emptied, their capacity kept, when taken again.
pub(crate) trait Scratch: Default {
    fn clear(&mut self);
}

impl<T> Scratch for Vec<T> {
    fn clear(&mut self) {
        Vec::clear(self);
    }
}

/// A thread's spare arrays of one kind: a ray's temporary lists (its candidates, its support
/// parts, the SCALIS tracer's breakpoints) reuse those of the thread's earlier rays, so that
/// tracing allocates nothing per ray once they have grown. Taken arrays are owned,
/// so a nested use takes another (or a new one) instead of borrowing the pool across a call.
pub(crate) struct ScratchPool<T>(std::cell::RefCell<Vec<T>>);

impl<T: Scratch> ScratchPool<T> {
    pub(crate) const fn new() -> Self {
        Self(std::cell::RefCell::new(Vec::new()))
    }

    /// Empty arrays from the pool, or new ones.
    pub(crate) fn take(pool: &'static std::thread::LocalKey<Self>) -> T {
        let mut spare = pool.with(|p| p.0.borrow_mut().pop()).unwrap_or_default();
        spare.clear();
        spare
    }

    /// Returns arrays to the pool for the thread's next ray.
    pub(crate) fn give_back(pool: &'static std::thread::LocalKey<Self>, spare: T) {
        pool.with(|p| p.0.borrow_mut().push(spare));
    }
}
