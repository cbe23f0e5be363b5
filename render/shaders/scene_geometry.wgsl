// scene_geometry.rs: what the tracer reads of an element's planes.

// scene_geometry.rs SceneGeometry::is_fracture_face
fn is_fracture_face(e: u32, plane: u32) -> bool {
    return params.counts.y == 2u || ((interior_faces[e] >> plane) & 1u) == 1u;
}

fn plane_normal(e: u32, plane: u32) -> vec3<f32> {
    return planes[plane_offsets[e] + plane].xyz;
}
