//! The contact between the floor's plane and a convex polyhedron (or a compound of them): every
//! corner within the prediction distance of the plane, the deepest four of them spread as wide
//! as they go.
//!
//! Dust rests on a plane rather than the floor's slab: parry meets a hull and the slab with GJK,
//! and with EPA for as long as the hull rests on it, while a hull and a plane meet in closed
//! form. But parry's own plane contact takes the corners of the hull's single face most facing
//! the plane, and at most four of them (a Voronoi cell's face has up to eight): a cell tilted
//! onto an edge, or lying on a face whose other corners were left out, sank 1.7 mm into the
//! floor. This dispatcher answers that one pair and leaves every other query to parry's.

use rapier3d_f64::math::{Pose, Real, Vector};
use rapier3d_f64::parry::query::details::NormalConstraints;
use rapier3d_f64::parry::query::{
    ClosestPoints, Contact, ContactManifold, ContactManifoldsWorkspace, NonlinearRigidMotion,
    PersistentQueryDispatcher, QueryDispatcher, ShapeCastHit, ShapeCastOptions, ShapeDistance, ShapeIntersection,
    TrackedContact, Unsupported,
};
use rapier3d_f64::parry::shape::{Compound, HalfSpace, PackedFeatureId, Shape};

/// The most contact points one manifold hands rapier's solver (it reads no more).
const MAX_POINTS: usize = 4;

/// Answers the contact manifolds between a half-space and a convex polyhedron or a compound of
/// convex polyhedra; every other query is unsupported here (parry's dispatcher answers it, see
/// [`dispatcher`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct PlaneContacts;

/// rapier's narrow-phase dispatcher with the plane contacts first.
pub fn dispatcher()
-> impl PersistentQueryDispatcher<rapier3d_f64::geometry::ContactManifoldData, rapier3d_f64::geometry::ContactData> + 'static
{
    PlaneContacts.chain(rapier3d_f64::parry::query::DefaultQueryDispatcher)
}

impl QueryDispatcher for PlaneContacts {
    fn intersection_test(&self, _: &Pose, _: &dyn Shape, _: &dyn Shape) -> Result<ShapeIntersection, Unsupported> {
        Err(Unsupported)
    }

    fn distance(&self, _: &Pose, _: &dyn Shape, _: &dyn Shape) -> Result<ShapeDistance, Unsupported> {
        Err(Unsupported)
    }

    fn contact(&self, _: &Pose, _: &dyn Shape, _: &dyn Shape, _: Real) -> Result<Option<Contact>, Unsupported> {
        Err(Unsupported)
    }

    fn closest_points(&self, _: &Pose, _: &dyn Shape, _: &dyn Shape, _: Real) -> Result<ClosestPoints, Unsupported> {
        Err(Unsupported)
    }

    fn cast_shapes(
        &self,
        _: &Pose,
        _: Vector,
        _: &dyn Shape,
        _: &dyn Shape,
        _: ShapeCastOptions,
    ) -> Result<Option<ShapeCastHit>, Unsupported> {
        Err(Unsupported)
    }

    fn cast_shapes_nonlinear(
        &self,
        _: &NonlinearRigidMotion,
        _: &dyn Shape,
        _: &NonlinearRigidMotion,
        _: &dyn Shape,
        _: Real,
        _: Real,
        _: bool,
    ) -> Result<Option<ShapeCastHit>, Unsupported> {
        Err(Unsupported)
    }
}

impl<ManifoldData: Default, ContactData: Default + Copy> PersistentQueryDispatcher<ManifoldData, ContactData>
    for PlaneContacts
{
    fn contact_manifolds(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
        prediction: Real,
        manifolds: &mut Vec<ContactManifold<ManifoldData, ContactData>>,
        _: &mut Option<ContactManifoldsWorkspace>,
    ) -> Result<(), Unsupported> {
        let pair = PlanePair::of(pos12, g1, g2).ok_or(Unsupported)?;
        manifolds.truncate(1);
        if manifolds.is_empty() {
            manifolds.push(ContactManifold::new());
        }
        pair.manifold(prediction, &mut manifolds[0]);
        Ok(())
    }

    fn contact_manifold_convex_convex(
        &self,
        pos12: &Pose,
        g1: &dyn Shape,
        g2: &dyn Shape,
        _: Option<&dyn NormalConstraints>,
        _: Option<&dyn NormalConstraints>,
        prediction: Real,
        manifold: &mut ContactManifold<ManifoldData, ContactData>,
    ) -> Result<(), Unsupported> {
        PlanePair::of(pos12, g1, g2).ok_or(Unsupported)?.manifold(prediction, manifold);
        Ok(())
    }
}

/// A half-space and a convex polyhedron or a compound of them, seen from the half-space.
struct PlanePair<'a> {
    plane: &'a HalfSpace,
    /// The solid's pose in the half-space's frame.
    solid_pose: Pose,
    solid: Solid<'a>,
    /// Whether the half-space is the pair's second shape.
    flipped: bool,
}

/// The convex polyhedra a solid is made of.
enum Solid<'a> {
    Hull(&'a [Vector]),
    Compound(&'a Compound),
}

impl Solid<'_> {
    /// Visits each corner of each part in the solid's frame, numbered through the parts.
    fn corners(&self, mut visit: impl FnMut(u32, Vector)) {
        match self {
            Solid::Hull(points) => points.iter().zip(0u32..).for_each(|(&point, id)| visit(id, point)),
            Solid::Compound(compound) => {
                let mut id = 0u32;
                for (pose, part) in compound.shapes() {
                    for &point in part.as_convex_polyhedron().map_or(&[][..], |hull| hull.points()) {
                        visit(id, *pose * point);
                        id += 1;
                    }
                }
            }
        }
    }
}

impl<'a> PlanePair<'a> {
    /// The pair, if `g1` and `g2` are a half-space and a solid of convex polyhedra (either order).
    fn of(pos12: &Pose, g1: &'a dyn Shape, g2: &'a dyn Shape) -> Option<PlanePair<'a>> {
        let (plane, solid, solid_pose, flipped) = match (g1.as_halfspace(), g2.as_halfspace()) {
            (Some(plane), None) => (plane, g2, *pos12, false),
            (None, Some(plane)) => (plane, g1, pos12.inverse(), true),
            _ => return None,
        };
        let solid = if let Some(hull) = solid.as_convex_polyhedron() {
            Solid::Hull(hull.points())
        } else {
            let compound = solid.as_compound()?;
            let convex = compound.shapes().iter().all(|(_, part)| part.as_convex_polyhedron().is_some());
            convex.then_some(Solid::Compound(compound))?
        };
        Some(PlanePair { plane, solid_pose, solid, flipped })
    }

    /// Fills `manifold` with the solid's corners within `prediction` of the plane (at most
    /// [`MAX_POINTS`]: the deepest, and then those that spread the points widest), carrying
    /// over the impulses of the corners it held before.
    fn manifold<M, C: Default + Copy>(&self, prediction: Real, manifold: &mut ContactManifold<M, C>) {
        let normal = self.plane.normal;
        // the plane's normal in the solid's frame: a corner's height is its offset along it
        // plus the solid's origin's height (the plane passes through its frame's origin)
        let normal_in_solid = self.solid_pose.rotation.inverse() * normal;
        let origin_height = self.solid_pose.translation.dot(normal);
        let height = |local: Vector| origin_height + local.dot(normal_in_solid);
        // most solids are in flight, far from the plane: one pass without allocating first
        let old = std::mem::take(&mut manifold.points);
        let mut lowest = Real::INFINITY;
        self.solid.corners(|_, local| lowest = lowest.min(height(local)));
        if lowest <= prediction {
            let mut corners: Vec<Corner> = Vec::new();
            self.solid.corners(|id, local| {
                let dist = height(local);
                if dist <= prediction {
                    let on_plane = self.solid_pose * local - normal * dist;
                    corners.push(Corner { id, local, on_plane, dist });
                }
            });
            for corner in spread(&corners) {
                manifold.points.push(TrackedContact::flipped(
                    corner.on_plane,
                    corner.local,
                    PackedFeatureId::face(0),
                    PackedFeatureId::vertex(corner.id),
                    corner.dist,
                    self.flipped,
                ));
            }
        }
        if self.flipped {
            manifold.local_n1 = -normal_in_solid;
            manifold.local_n2 = normal;
        } else {
            manifold.local_n1 = normal;
            manifold.local_n2 = -normal_in_solid;
        }
        manifold.subshape1 = 0;
        manifold.subshape2 = 0;
        manifold.match_contacts(&old);
    }
}

/// A corner of the solid near the plane.
#[derive(Debug, Clone, Copy)]
struct Corner {
    /// Its number among the solid's corners (the contact's feature, for carrying impulses over).
    id: u32,
    /// Where it is in the solid's frame.
    local: Vector,
    /// Its projection onto the plane, in the plane's frame.
    on_plane: Vector,
    /// Its signed distance to the plane (negative: below it).
    dist: Real,
}

/// At most [`MAX_POINTS`] of `corners`: all of them if they are that few, else the deepest, the
/// one farthest from it, the one that makes the largest triangle with those two, and the one
/// that adds the most area outside that triangle (the first of equals, in the corners' order).
fn spread(corners: &[Corner]) -> Vec<Corner> {
    if corners.len() <= MAX_POINTS {
        return corners.to_vec();
    }
    let mut kept: Vec<Corner> = Vec::with_capacity(MAX_POINTS);
    let best_new = |kept: &[Corner], score: &dyn Fn(&Corner) -> Real| {
        let fresh = corners.iter().filter(|c| kept.iter().all(|k| k.id != c.id));
        let mut best: Option<(&Corner, Real)> = None;
        for corner in fresh {
            let value = score(corner);
            if best.is_none_or(|(_, top)| value > top) {
                best = Some((corner, value));
            }
        }
        *best.map(|(corner, _)| corner).unwrap_or(&corners[0])
    };
    let area = |p: Vector, q: Vector, r: Vector| (q - p).cross(r - p).length();
    let a = best_new(&kept, &|c| -c.dist);
    kept.push(a);
    let b = best_new(&kept, &|c| (c.on_plane - a.on_plane).length_squared());
    kept.push(b);
    let c = best_new(&kept, &|c| area(a.on_plane, b.on_plane, c.on_plane));
    kept.push(c);
    let triangle = area(a.on_plane, b.on_plane, c.on_plane);
    let d = best_new(&kept, &|d| {
        let p = d.on_plane;
        area(p, a.on_plane, b.on_plane) + area(p, b.on_plane, c.on_plane) + area(p, c.on_plane, a.on_plane) - triangle
    });
    kept.push(d);
    kept
}
