//! What the loom model checks share (`tests/table_loom.rs`, `tests/contact_ring_loom.rs`).

/// Runs `f` under loom, bounded to one preemption per execution unless `LOOM_MAX_PREEMPTIONS`
/// says otherwise (see the files' module comments for what the bound catches).
pub fn model(f: impl Fn() + Sync + Send + 'static) {
    let mut builder = loom::model::Builder::new();
    if builder.preemption_bound.is_none() {
        builder.preemption_bound = Some(1);
    }
    builder.check(f);
}
