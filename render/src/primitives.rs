//! Ray tests against the elements, all convex polytopes given by planes (a cube has 6, a
//! tetrahedron 4, a Voronoi cell as many as its faces), and the trimtope rules of Levine et al.'s
//! Fig. 4 for cells with embedded surface triangles. Written as plain functions of plain data to
//! read like their twins in `shaders/primitives.wgsl`.

use crate::element_kdtree::Aabb;

/// A plane [nx, ny, nz, d] with unit outward normal n: inside where n . x <= d.
pub type Plane = [f32; 4];

/// Elements are widened by this fraction of their size in ray tests, so that rays along a seam
/// between touching elements hit one of them (no crack pixels).
pub const WIDEN: f32 = 2e-5;

/// Entry and exit of a ray through a convex polytope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Ray parameter where it enters (may be behind the origin: then the origin is inside).
    pub t_in: f32,
    /// Ray parameter where it leaves.
    pub t_out: f32,
    /// The plane it enters through (index into the element's planes; u32::MAX if it starts inside
    /// and never crossed one).
    pub plane_in: u32,
    /// The plane it leaves through.
    pub plane_out: u32,
}

pub(crate) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(crate) fn along(origin: [f32; 3], direction: [f32; 3], t: f32) -> [f32; 3] {
    [origin[0] + t * direction[0], origin[1] + t * direction[1], origin[2] + t * direction[2]]
}

/// The span of the ray `origin + t direction` inside the polytope `planes`, or None when the
/// line misses the polytope widened by `slack`. The widening only decides hit or miss, so that
/// rays along a seam between touching elements hit one of them; the span itself is the exact
/// polytope's (for a ray that only grazes the widened rim it is empty, t_in > t_out, and t_in is
/// where it passes the rim).
pub fn polytope_span(planes: &[Plane], slack: f32, origin: [f32; 3], direction: [f32; 3]) -> Option<Span> {
    let mut span = Span { t_in: f32::NEG_INFINITY, t_out: f32::INFINITY, plane_in: u32::MAX, plane_out: u32::MAX };
    let (mut wide_in, mut wide_out) = (f32::NEG_INFINITY, f32::INFINITY);
    let mut outside = false;
    for (c, chunk) in planes.chunks(SPAN_LANES).enumerate() {
        // the arithmetic lane by lane (padded with the chunk's last plane), then the choices in order
        let plane: [Plane; SPAN_LANES] = std::array::from_fn(|k| chunk[k.min(chunk.len() - 1)]);
        let normal = |k: usize| [plane[k][0], plane[k][1], plane[k][2]];
        let facing: [f32; SPAN_LANES] = std::array::from_fn(|k| dot(normal(k), direction));
        let room: [f32; SPAN_LANES] = std::array::from_fn(|k| plane[k][3] - dot(normal(k), origin));
        let t: [f32; SPAN_LANES] = std::array::from_fn(|k| room[k] / facing[k]);
        let wide: [f32; SPAN_LANES] = std::array::from_fn(|k| (room[k] + slack) / facing[k]);
        for k in 0..chunk.len() {
            let index = (c * SPAN_LANES + k) as u32;
            outside |= facing[k] == 0.0 && room[k] + slack < 0.0;
            let (entering, leaving) = (facing[k] < 0.0, facing[k] > 0.0);
            wide_in = if entering { wide_in.max(wide[k]) } else { wide_in };
            wide_out = if leaving { wide_out.min(wide[k]) } else { wide_out };
            let later = entering && t[k] > span.t_in;
            span.t_in = if later { t[k] } else { span.t_in };
            span.plane_in = if later { index } else { span.plane_in };
            let sooner = leaving && t[k] < span.t_out;
            span.t_out = if sooner { t[k] } else { span.t_out };
            span.plane_out = if sooner { index } else { span.plane_out };
        }
    }
    (!outside && wide_in <= wide_out).then_some(span)
}

/// Whether `planes` are six in opposite pairs, as [`cube_planes`] makes them: plane 2k + 1's
/// normal is plane 2k's negated, bit for bit (what [`CubeFromOrigin`] needs).
pub fn in_opposite_pairs(planes: &[Plane]) -> bool {
    planes.len() == 6 && planes.chunks(2).all(|pair| (0..3).all(|i| pair[1][i].to_bits() == (-pair[0][i]).to_bits()))
}

/// A cube whose six planes are [`in_opposite_pairs`], given as the normals of planes 0, 2 and 4
/// (`axes`) and the six planes' distances, seen from one origin: the room from the origin to each
/// plane along the plane's own normal (plane 2k's in `upper[k]`, plane 2k + 1's in `lower[k]`),
/// which every ray from that origin shares. Its span (its [`entry`](CubeFromOrigin::entry) and
/// [`exit`](CubeFromOrigin::exit)) is [`polytope_span`]'s to the bit, from half the arithmetic and
/// a third of the bytes. Negating a normal negates its dot products exactly (every product and sum
/// rounds symmetrically), so one facing and one distance per pair give both planes': of a pair,
/// the plane the ray faces is entered and the other left, and the pairs are weighed in order, as
/// the planes are there (ties go to the lower).
#[derive(Debug, Clone, Copy)]
pub struct CubeFromOrigin<'a> {
    axes: &'a [[f32; 3]; 3],
    upper: [f32; 3],
    lower: [f32; 3],
}

impl<'a> CubeFromOrigin<'a> {
    /// The cube with axes `axes` and plane distances `distances`, from `origin`.
    pub fn new(axes: &'a [[f32; 3]; 3], distances: &[f32; 6], origin: [f32; 3]) -> CubeFromOrigin<'a> {
        let mut cube = CubeFromOrigin { axes, upper: [0.0; 3], lower: [0.0; 3] };
        for (k, &normal) in axes.iter().enumerate() {
            let distance = dot(normal, origin);
            (cube.upper[k], cube.lower[k]) = (distances[2 * k] - distance, distances[2 * k + 1] + distance);
        }
        cube
    }

    #[cfg(test)]
    /// The span of the ray from the origin along `direction` inside the cube widened by `slack`
    /// ([`polytope_span`]).
    pub fn span(&self, slack: f32, direction: [f32; 3]) -> Option<Span> {
        self.span_parts::<true, true>(slack, direction)
    }

    /// Where the ray from the origin along `direction` enters the cube: the t and plane of its
    /// span when that exists, starts at or after `t_min` and enters through a plane, else None;
    /// without the exit's three divisions (a nearest-hit search asks for entries only).
    pub fn entry(&self, slack: f32, direction: [f32; 3], t_min: f32) -> Option<(f32, u32)> {
        self.span_parts::<true, false>(slack, direction)
            .filter(|span| span.t_in >= t_min && span.plane_in != u32::MAX)
            .map(|span| (span.t_in, span.plane_in))
    }

    /// Where the ray from the origin along `direction` leaves the cube, t and plane, when its span
    /// exists; without the entry's three divisions (a walk through a union asks for exits only).
    pub fn exit(&self, slack: f32, direction: [f32; 3]) -> Option<(f32, u32)> {
        self.span_parts::<false, true>(slack, direction).map(|span| (span.t_out, span.plane_out))
    }

    /// The span, its entry computed only with `ENTRY` and its exit only with `EXIT` (else left as
    /// an empty span's: infinite, no plane); whether it exists does not depend on them.
    fn span_parts<const ENTRY: bool, const EXIT: bool>(&self, slack: f32, direction: [f32; 3]) -> Option<Span> {
        let mut span = Span { t_in: f32::NEG_INFINITY, t_out: f32::INFINITY, plane_in: u32::MAX, plane_out: u32::MAX };
        let (mut wide_in, mut wide_out) = (f32::NEG_INFINITY, f32::INFINITY);
        let mut outside = false;
        for (k, &normal) in self.axes.iter().enumerate() {
            // the rooms of plane 2k (facing `facing`) and 2k + 1 (facing -`facing`)
            let (facing, upper, lower) = (dot(normal, direction), self.upper[k], self.lower[k]);
            outside |= facing == 0.0 && (upper + slack < 0.0 || lower + slack < 0.0);
            if facing == 0.0 {
                // neither plane entered nor left (a NaN facing goes on, and changes nothing: every
                // comparison with it fails and max and min pass over it, as in `polytope_span`)
                continue;
            }
            let (room_in, room_out, plane_in) =
                if facing < 0.0 { (upper, lower, 2 * k as u32) } else { (lower, upper, 2 * k as u32 + 1) };
            // the entered plane faces -|facing|, the left one |facing|
            let speed = facing.abs();
            wide_in = wide_in.max((room_in + slack) / -speed);
            wide_out = wide_out.min((room_out + slack) / speed);
            if ENTRY {
                let t_in = room_in / -speed;
                if t_in > span.t_in {
                    (span.t_in, span.plane_in) = (t_in, plane_in);
                }
            }
            if EXIT {
                let t_out = room_out / speed;
                if t_out < span.t_out {
                    (span.t_out, span.plane_out) = (t_out, plane_in ^ 1);
                }
            }
        }
        (!outside && wide_in <= wide_out).then_some(span)
    }
}

/// Planes whose arithmetic [`polytope_span`] does side by side (a cube's 6 fit).
const SPAN_LANES: usize = 8;

/// Whether `point` lies inside the polytope widened by `slack`.
pub fn polytope_contains(planes: &[Plane], slack: f32, point: [f32; 3]) -> bool {
    planes.iter().all(|p| dot([p[0], p[1], p[2]], point) <= p[3] + slack)
}

/// [`polytope_contains`] of six planes [`in_opposite_pairs`], given as [`CubeFromOrigin`] takes
/// them: the same answer to the bit from one dot product a pair.
pub fn paired_contains(axes: &[[f32; 3]; 3], distances: &[f32; 6], slack: f32, point: [f32; 3]) -> bool {
    axes.iter().enumerate().all(|(k, &normal)| {
        let along = dot(normal, point);
        along <= distances[2 * k] + slack && -along <= distances[2 * k + 1] + slack
    })
}

/// The 6 planes of a cube with centre `centre`, half size `half` and axes `axes` (unit, right-handed).
pub fn cube_planes(centre: [f32; 3], half: f32, axes: [[f32; 3]; 3]) -> [Plane; 6] {
    let mut planes = [[0.0; 4]; 6];
    for (k, axis) in axes.iter().enumerate() {
        let c = dot(*axis, centre);
        planes[2 * k] = [axis[0], axis[1], axis[2], c + half];
        planes[2 * k + 1] = [-axis[0], -axis[1], -axis[2], -c + half];
    }
    planes
}

/// The 4 planes of a tetrahedron (outward normals whatever its vertex order).
pub fn tet_planes(vertices: [[f32; 3]; 4]) -> [Plane; 4] {
    let centre = [0, 1, 2].map(|a| (vertices[0][a] + vertices[1][a] + vertices[2][a] + vertices[3][a]) * 0.25);
    let mut planes = [[0.0; 4]; 4];
    for (k, plane) in planes.iter_mut().enumerate() {
        let [a, b, c] = [vertices[(k + 1) % 4], vertices[(k + 2) % 4], vertices[(k + 3) % 4]];
        let mut n = cross(sub(b, a), sub(c, a));
        let length = dot(n, n).sqrt();
        n = n.map(|v| v / length);
        if dot(n, sub(centre, a)) > 0.0 {
            n = n.map(|v| -v);
        }
        *plane = [n[0], n[1], n[2], dot(n, a)];
    }
    planes
}

/// Ray-triangle intersection (Moller-Trumbore): the ray parameter and whether the ray meets the
/// triangle's front (outward, counter-clockwise) side.
pub fn triangle_hit(origin: [f32; 3], direction: [f32; 3], triangle: &[[f32; 3]; 3]) -> Option<(f32, bool)> {
    let e1 = sub(triangle[1], triangle[0]);
    let e2 = sub(triangle[2], triangle[0]);
    let p = cross(direction, e2);
    let det = dot(e1, p);
    if det == 0.0 {
        return None;
    }
    let inverse = 1.0 / det;
    let s = sub(origin, triangle[0]);
    let u = dot(s, p) * inverse;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(direction, q) * inverse;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = dot(e2, q) * inverse;
    // det = e1 . (d x e2) = -d . (e1 x e2): positive when the ray runs against the normal
    Some((t, det > 0.0))
}

/// How a ray meets a trimtope (and, as a face entry or a miss, any other polytope).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrimtopeHit {
    /// The ray passes: the cell's entry point is outside the surface (Fig. 4, ray A).
    Miss,
    /// The ray hits the cell's entry face, inside the surface (rays B and D): a fracture face.
    Face {
        /// Ray parameter.
        t: f32,
        /// The plane entered through.
        plane: u32,
    },
    /// The ray hits the embedded surface from outside (ray C).
    Surface {
        /// Ray parameter.
        t: f32,
        /// The triangle hit.
        triangle: u32,
    },
}

/// A trimtope as a ray meets it: a Voronoi cell with the surface triangles embedded in it.
#[derive(Debug, Clone, Copy)]
pub struct Trimtope<'a> {
    /// The cell's planes.
    pub planes: &'a [Plane],
    /// The embedded surface triangles, in groups of [`TRIANGLE_GROUP`].
    pub triangles: &'a [[[f32; 3]; 3]],
    /// The bounds of each group of triangles ([`triangle_groups`]).
    pub groups: &'a [Aabb],
    /// The cell's site.
    pub site: [f32; 3],
    /// The widening of the hit-or-miss test ([`polytope_span`]).
    pub slack: f32,
    /// Bounds of the part of the cell inside the surface, which every hit lies in.
    pub bounds: &'a Aabb,
}

/// The rules of Levine et al.'s Fig. 4 for a ray meeting the trimtope `cell`, nearer than `t_max`
/// and no earlier than `t_min` (a hit beyond `t_max` may be given or not). Within the cell, the first triangle the ray meets decides: front side first (it
/// enters the surface there) is a surface hit (C); back side first (it was inside already) is a
/// hit on the entry face (D). Meeting no triangle, a secondary ray from the entry point to the
/// site decides: a front side on the way means the entry point is outside the surface, a miss
/// (A); otherwise a hit on the entry face (B).
pub fn trimtope_hit(cell: &Trimtope, origin: [f32; 3], direction: [f32; 3], (t_min, t_max): (f32, f32)) -> TrimtopeHit {
    let Trimtope { planes, triangles, groups, site, slack, bounds } = *cell;
    // every hit lies in the bounds: a ray that misses them before t_max passes (a cell reaching
    // out from the surface is far larger than they are)
    if !segment_meets_box(origin, direction, t_min, t_max, bounds) {
        return TrimtopeHit::Miss;
    }
    let Some(span) = polytope_span(planes, slack, origin, direction) else {
        return TrimtopeHit::Miss;
    };
    // a ray grazing the widened rim has an empty exact span: treat it as a point at t_in
    let t_out = span.t_out.max(span.t_in);
    let t_in = span.t_in.max(t_min);
    if t_in > t_out {
        return TrimtopeHit::Miss;
    }
    match first_triangle(triangles, groups, origin, direction, t_in, t_out) {
        Some((t, true, triangle)) => TrimtopeHit::Surface { t, triangle },
        Some((_, false, _)) => TrimtopeHit::Face { t: t_in, plane: span.plane_in },
        None => {
            let entry = along(origin, direction, t_in);
            // a face hit is at the entry point, inside the surface: inside the bounds
            if !bounds.holds(entry) {
                return TrimtopeHit::Miss;
            }
            let to_site = sub(site, entry);
            match first_triangle(triangles, groups, entry, to_site, 0.0, 1.0) {
                Some((_, true, _)) => TrimtopeHit::Miss,
                _ => TrimtopeHit::Face { t: t_in, plane: span.plane_in },
            }
        }
    }
}

/// The first of `triangles` the ray meets with a parameter in [t0, t1]: its parameter, whether
/// it was met from the front, and its index (the lowest index among equal parameters). Groups of
/// triangles whose bounds the segment misses are skipped.
fn first_triangle(
    triangles: &[[[f32; 3]; 3]],
    groups: &[Aabb],
    origin: [f32; 3],
    direction: [f32; 3],
    t0: f32,
    t1: f32,
) -> Option<(f32, bool, u32)> {
    let mut first: Option<(f32, bool, u32)> = None;
    for (group, bounds) in groups.iter().enumerate() {
        if !segment_meets_box(origin, direction, t0, t1, bounds) {
            continue;
        }
        let start = group * TRIANGLE_GROUP;
        let members = triangles[start..].iter().take(TRIANGLE_GROUP);
        for (index, triangle) in (start..).zip(members) {
            if let Some((t, front)) = triangle_hit(origin, direction, triangle)
                && t >= t0
                && t <= t1
                && first.is_none_or(|(best, _, _)| t < best)
            {
                first = Some((t, front, index as u32));
            }
        }
    }
    first
}

/// A trimtope's surface triangles are tested in groups of this many consecutive ones, each
/// behind a bounding box: a ray through a cell that carries hundreds of triangles tests the few
/// groups near its path.
pub const TRIANGLE_GROUP: usize = 8;

/// Orders `triangles` along a Z-order curve of their centroids, so that the groups of
/// [`TRIANGLE_GROUP`] consecutive triangles are compact.
pub fn sort_triangles_spatially(triangles: &mut [[[f32; 3]; 3]]) {
    if triangles.len() <= TRIANGLE_GROUP {
        return;
    }
    let centroid = |t: &[[f32; 3]; 3]| [0, 1, 2].map(|a| (t[0][a] + t[1][a] + t[2][a]) / 3.0);
    let bounds = triangles.iter().fold(Aabb::EMPTY, |b, t| {
        let c = centroid(t);
        b.union(&Aabb { min: c, max: c })
    });
    let code = |t: &[[f32; 3]; 3]| {
        let c = centroid(t);
        let cell = [0, 1, 2].map(|a| {
            let extent = bounds.max[a] - bounds.min[a];
            let unit = if extent > 0.0 { (c[a] - bounds.min[a]) / extent } else { 0.0 };
            (unit * 1023.0) as u32
        });
        (0..10).fold(0u32, |code, bit| {
            code | ((cell[0] >> bit & 1) << (3 * bit))
                | ((cell[1] >> bit & 1) << (3 * bit + 1))
                | ((cell[2] >> bit & 1) << (3 * bit + 2))
        })
    };
    triangles.sort_by_cached_key(code);
}

/// Bounds of each group of [`TRIANGLE_GROUP`] consecutive `triangles`, widened by 1e-3 of the
/// group's size and 1e-6 of its distance from the origin, so that rounding in the ray tests never
/// skips a group holding a hit.
pub fn triangle_groups(triangles: &[[[f32; 3]; 3]]) -> Vec<Aabb> {
    triangles
        .chunks(TRIANGLE_GROUP)
        .map(|group| {
            let b = group.iter().flatten().fold(Aabb::EMPTY, |b, v| b.union(&Aabb { min: *v, max: *v }));
            let size = (0..3).map(|a| b.max[a] - b.min[a]).fold(0.0f32, f32::max);
            let far = b.min.iter().chain(&b.max).fold(0.0f32, |m, v| m.max(v.abs()));
            let pad = 1e-3 * size + 1e-6 * far;
            Aabb { min: b.min.map(|v| v - pad), max: b.max.map(|v| v + pad) }
        })
        .collect()
}

/// Whether the segment `origin + t direction`, t in [t0, t1], meets the box (slab test; an axis
/// the direction does not move along needs the origin within the slab), with a margin of 1e-5
/// of the exit parameter.
pub fn segment_meets_box(origin: [f32; 3], direction: [f32; 3], t0: f32, t1: f32, bounds: &Aabb) -> bool {
    let (mut near, mut far) = (t0, t1);
    for axis in 0..3 {
        if direction[axis] == 0.0 {
            if origin[axis] < bounds.min[axis] || origin[axis] > bounds.max[axis] {
                return false;
            }
            continue;
        }
        let inverse = 1.0 / direction[axis];
        let a = (bounds.min[axis] - origin[axis]) * inverse;
        let b = (bounds.max[axis] - origin[axis]) * inverse;
        near = near.max(a.min(b));
        far = far.min(a.max(b));
    }
    // the relative margin covers rounding that grows with the distance from the ray's origin
    near <= far + 1e-5 * far.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    const AXES: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    #[test]
    fn a_cube_span_is_its_slab_interval() {
        let planes = cube_planes([1.0, 2.0, 3.0], 0.5, AXES);
        let span = polytope_span(&planes, 0.0, [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]).expect("hit");
        assert_eq!((span.t_in, span.t_out), (2.5, 3.5));
        assert_eq!(planes[span.plane_in as usize][2], -1.0, "enters through the -z face");
        assert!(polytope_span(&planes, 0.0, [3.0, 2.0, 0.0], [0.0, 0.0, 1.0]).is_none());
        assert!(polytope_contains(&planes, 0.0, [1.2, 2.3, 3.4]));
        assert!(!polytope_contains(&planes, 0.0, [1.6, 2.0, 3.0]));
    }

    /// The paired span is the general one to the bit, on random turned cubes and rays, rays
    /// along the cubes' axes and the world's (zero facings) and origins on their planes included;
    /// so are the paired point test and the entry and exit from an origin's shared rooms.
    #[test]
    fn a_cubes_span_from_its_slabs_is_the_polytope_span_to_the_bit() {
        let mut rng = shatter_core::random::SplitMix64::new(11);
        let mut r = move || rng.next_f64() as f32 - 0.5;
        let bits = |span: Option<Span>| span.map(|s| (s.t_in.to_bits(), s.t_out.to_bits(), s.plane_in, s.plane_out));
        let (mut hits, mut misses, mut insides, mut entries) = (0, 0, 0, 0);
        for trial in 0..20_000 {
            let turned = glam::Quat::from_xyzw(r(), r(), r(), r()).normalize();
            let axes = if trial % 4 == 0 {
                AXES
            } else {
                [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z].map(|a| (turned * a).to_array())
            };
            let centre = [r(), r(), r()];
            let planes = cube_planes(centre, 0.2 + r().abs(), axes);
            assert!(in_opposite_pairs(&planes));
            let mut origin = [2.0 * r(), 2.0 * r(), 2.0 * r()];
            let mut direction = match trial % 5 {
                0 => axes[trial % 3],
                1 => [0.0, r(), r()],
                _ => [r(), r(), r()],
            };
            if trial % 7 == 0 {
                // on a plane of the cube, or aimed so that a facing is zero
                origin = [centre[0] + axes[0][0] * 0.7, centre[1], centre[2]];
                direction = cross(axes[1], axes[2]);
            }
            let slack = if trial % 3 == 0 { 0.0 } else { 1e-3 };
            let expected = polytope_span(&planes, slack, origin, direction);
            let distances = planes.map(|p| p[3]);
            let cube = CubeFromOrigin::new(&axes, &distances, origin);
            assert_eq!(bits(cube.span(slack, direction)), bits(expected), "trial {trial}");
            // the entry: the span's, where it starts at or after t_min through a plane (t_min
            // before, at and after the span's start)
            for t_min in [0.0, expected.map_or(0.0, |s| s.t_in), expected.map_or(1.0, |s| s.t_in + 1e-3)] {
                let want = expected
                    .filter(|s| s.t_in >= t_min && s.plane_in != u32::MAX)
                    .map(|s| (s.t_in.to_bits(), s.plane_in));
                let got = cube.entry(slack, direction, t_min).map(|(t, plane)| (t.to_bits(), plane));
                assert_eq!(got, want, "trial {trial}, t_min {t_min}");
                entries += usize::from(got.is_some());
            }
            let exit = cube.exit(slack, direction).map(|(t, plane)| (t.to_bits(), plane));
            assert_eq!(exit, expected.map(|s| (s.t_out.to_bits(), s.plane_out)), "trial {trial}");
            // inside (mid-span), on the rim (where the span begins) or anywhere
            let t = match expected {
                Some(span) if trial % 3 == 0 => 0.5 * (span.t_in + span.t_out),
                Some(span) if trial % 3 == 1 => span.t_in,
                _ => 1.0,
            };
            let point = along(origin, direction, t);
            let inside = polytope_contains(&planes, slack, point);
            assert_eq!(paired_contains(&axes, &distances, slack, point), inside, "trial {trial}");
            insides += usize::from(inside);
            if expected.is_some() { hits += 1 } else { misses += 1 }
        }
        assert!(hits > 3000 && misses > 3000, "{hits} hits, {misses} misses");
        assert!(entries > 3000, "{entries} entries");
        assert!(insides > 3000 && insides < 17_000, "{insides} points inside");
        let mut unpaired = cube_planes([0.0; 3], 0.5, AXES);
        unpaired[3][1] = -0.999_999_9;
        assert!(!in_opposite_pairs(&unpaired));
        assert!(!in_opposite_pairs(&tet_planes([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])));
    }

    #[test]
    fn tet_planes_point_outward_for_either_vertex_order() {
        let tet = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let flipped = [tet[1], tet[0], tet[2], tet[3]];
        for vertices in [tet, flipped] {
            let planes = tet_planes(vertices);
            assert!(polytope_contains(&planes, 1e-6, [0.1, 0.1, 0.1]));
            assert!(!polytope_contains(&planes, 0.0, [0.5, 0.5, 0.5]));
        }
    }

    /// A unit cube cell with site at its centre and a surface plane z = 0.2 (outward +z) across it:
    /// the surface lies above the site, in the forward direction, as in Fig. 4.
    fn cell() -> ([Plane; 6], Vec<[[f32; 3]; 3]>, [f32; 3]) {
        let planes = cube_planes([0.0; 3], 0.5, AXES);
        let z = 0.2;
        let triangles =
            vec![[[-0.5, -0.5, z], [0.5, -0.5, z], [0.5, 0.5, z]], [[-0.5, -0.5, z], [0.5, 0.5, z], [-0.5, 0.5, z]]];
        (planes, triangles, [0.0, 0.0, 0.0])
    }

    #[test]
    fn the_four_cases_of_fig_4() {
        let (planes, triangles, site) = cell();
        let groups = triangle_groups(&triangles);
        // the part of the cell below the surface
        let bounds = Aabb { min: [-0.5; 3], max: [0.5, 0.5, 0.2] };
        let cell =
            Trimtope { planes: &planes, triangles: &triangles, groups: &groups, site, slack: 0.0, bounds: &bounds };
        let hit = |origin: [f32; 3], direction: [f32; 3]| trimtope_hit(&cell, origin, direction, (0.0, f32::INFINITY));
        // A: enters and leaves above the surface (outside the solid), no triangle on the way:
        // the secondary ray to the site crosses the surface's front: a miss
        assert_eq!(hit([-2.0, 0.0, 0.4], [1.0, 0.0, 0.0]), TrimtopeHit::Miss);
        // B: enters and leaves below the surface (inside the solid): the entry face
        assert_eq!(hit([-2.0, 0.0, -0.3], [1.0, 0.0, 0.0]), TrimtopeHit::Face { t: 1.5, plane: 1 });
        // C: comes down from above through the surface's front: a surface hit
        let c = hit([0.1, 0.1, 2.0], [0.0, 0.0, -1.0]);
        assert!(matches!(c, TrimtopeHit::Surface { t, .. } if (t - 1.8).abs() < 1e-6), "{c:?}");
        // D: comes up from below: meets the surface's back first, so the entry face is the hit
        let d = hit([0.1, 0.1, -2.0], [0.0, 0.0, 1.0]);
        assert_eq!(d, TrimtopeHit::Face { t: 1.5, plane: 5 });
    }

    /// Grouping only skips work: against a cell carrying hundreds of random triangles, random
    /// rays get the same answer with the groups' bounds as with bounds that skip nothing.
    #[test]
    fn triangle_groups_change_no_answer() {
        let mut state = 7u64;
        let mut r = move || {
            state = shatter_core::random::splitmix64(state);
            (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let planes = cube_planes([0.0; 3], 0.5, AXES);
        let mut triangles: Vec<[[f32; 3]; 3]> = (0..300)
            .map(|_| {
                let centre = [r(), r(), r()];
                [0, 1, 2].map(|_| [0, 1, 2].map(|a| centre[a] + 0.1 * r()))
            })
            .collect();
        sort_triangles_spatially(&mut triangles);
        let groups = triangle_groups(&triangles);
        assert_eq!(groups.len(), 300usize.div_ceil(TRIANGLE_GROUP));
        let everywhere = vec![Aabb { min: [f32::NEG_INFINITY; 3], max: [f32::INFINITY; 3] }; groups.len()];
        let mut kinds = [0usize; 3];
        for _ in 0..4000 {
            let origin = [4.0 * r(), 4.0 * r(), 4.0 * r()];
            let target = [r(), r(), r()];
            let direction = [0, 1, 2].map(|a| target[a] - origin[a]);
            let site = [0.02 * r(), 0.02 * r(), 0.02 * r()];
            let bounds = &everywhere[0];
            let cell = Trimtope { planes: &planes, triangles: &triangles, groups: &groups, site, slack: 0.0, bounds };
            let grouped = trimtope_hit(&cell, origin, direction, (0.0, f32::INFINITY));
            let brute =
                trimtope_hit(&Trimtope { groups: &everywhere, ..cell }, origin, direction, (0.0, f32::INFINITY));
            assert_eq!(grouped, brute);
            kinds[match grouped {
                TrimtopeHit::Miss => 0,
                TrimtopeHit::Face { .. } => 1,
                TrimtopeHit::Surface { .. } => 2,
            }] += 1;
        }
        assert!(kinds.iter().all(|&k| k > 100), "every kind of answer is exercised: {kinds:?}");
    }

    #[test]
    fn a_segment_meets_a_box_only_within_its_parameter_range() {
        let unit = Aabb { min: [0.0; 3], max: [1.0; 3] };
        let (origin, direction) = ([-1.0, 0.5, 0.5], [1.0, 0.0, 0.0]);
        assert!(segment_meets_box(origin, direction, 0.0, 10.0, &unit));
        assert!(segment_meets_box(origin, direction, 1.5, 1.6, &unit));
        assert!(!segment_meets_box(origin, direction, 0.0, 0.9, &unit));
        assert!(!segment_meets_box(origin, direction, 2.1, 3.0, &unit));
        assert!(!segment_meets_box([-1.0, 1.5, 0.5], direction, 0.0, 10.0, &unit), "parallel, outside the slab");
        assert!(segment_meets_box([0.5, 0.5, 3.0], [0.0, 0.0, -1.0], 2.0, 2.5, &unit));
    }
}
