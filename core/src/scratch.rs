//! Per-thread scratch arrays for the CPU tracer's per-ray lists (issue 18: no allocation per
//! ray once the arrays have grown).

/// A thread's spare arrays of one kind: a ray's temporary lists (its support parts, the SCALIS
/// tracer's breakpoints) reuse those of the thread's earlier rays, so that tracing allocates
/// nothing per ray once they have grown (issue 18). Taken arrays are owned, so a nested use
/// takes another (or a new one) instead of borrowing the pool across a call.
pub(crate) struct ScratchPool<T>(std::cell::RefCell<Vec<Vec<T>>>);

impl<T> ScratchPool<T> {
    pub(crate) const fn new() -> Self {
        Self(std::cell::RefCell::new(Vec::new()))
    }

    /// An empty array from the pool, or a new one.
    pub(crate) fn take(pool: &'static std::thread::LocalKey<Self>) -> Vec<T> {
        let mut spare = pool.with(|p| p.0.borrow_mut().pop()).unwrap_or_default();
        spare.clear();
        spare
    }

    /// Returns an array to the pool for the thread's next ray.
    pub(crate) fn give_back(pool: &'static std::thread::LocalKey<Self>, spare: Vec<T>) {
        pool.with(|p| p.0.borrow_mut().push(spare));
    }
}
