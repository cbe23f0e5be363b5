// mattes.rs: the surface kinds and the per-pixel counts of the fragments and surface kinds
// seen first.

const SURFACE_NONE: u32 = 0u;
const SURFACE_OUTER: u32 = 1u;
const SURFACE_FRACTURE: u32 = 2u;
const SURFACE_FLOOR: u32 = 3u;

// mattes.rs MatteCounts::add
fn add_matte_sample(matte: ptr<function, MatteOut>, fragment: u32, surface: u32) {
    (*matte).surfaces.w += 1u;
    if (surface != SURFACE_NONE) {
        (*matte).surfaces[surface - 1u] += 1u;
    }
    if (fragment == 0u) {
        return;
    }
    for (var k = 0u; k < 8u; k++) {
        let slot = (*matte).fragments[k];
        if (slot.x == fragment || slot.x == 0u) {
            (*matte).fragments[k] = vec2<u32>(fragment, slot.y + 1u);
            return;
        }
    }
}
