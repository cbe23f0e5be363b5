// element_kdtree.rs: the k-d tree's node layout and its traversal's reciprocal directions.

const LEAF: u32 = 3u;
const SHORT_STACK: u32 = 4u;

// element_kdtree.rs inverse_component
fn inverse_component(d: f32) -> f32 {
    let tiny = 1e-30;
    if (abs(d) < tiny) {
        return 1.0 / select(tiny, -tiny, d < 0.0 || (d == 0.0 && bitcast<u32>(d) != 0u));
    }
    return 1.0 / d;
}
