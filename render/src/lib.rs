//! The post and render stages of shatter: fragments by BFS over intact element adjacency, rigid
//! motion by Kabsch per fragment, and a k-d tree ray tracer (short-stack traversal) for cube,
//! tetrahedron and trimtope CSG unions under spherical-harmonic environment light, to EXR.
//!
//! Not built yet: post arrives with issue #7, the renderer with issue #8.
