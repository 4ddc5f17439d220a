//! The triangles of a small scene that can block a shadow ray.
//!
//! A shadow ray is a segment from a point of the scene to a point of a light, both ends
//! offset off their surfaces towards each other ([`crate::integrator`]'s `segment_to`). Some
//! triangles can block no such segment, whatever its ends:
//!
//! - **A triangle whose plane has the whole scene on one side and every light strictly on
//!   that side** (the floor, walls and ceiling of a room around everything else). A segment
//!   from a point on that (closed) side to a point strictly inside it has every other point
//!   strictly inside too: it never meets the plane past its start.
//! - **A triangle whose plane holds every light, when every light is a surface** (a flat
//!   light's own triangles, and those coplanar with them). A point in that plane receives
//!   nothing from the lights (it sees them edge-on, and light sampling gives it no sample:
//!   `Light::sample`); from a point off it, a segment meets the plane only at its light end,
//!   which is offset off the light towards the segment's start, so it stops short of the
//!   plane.
//!
//! Leaving those out changes no answer in exact arithmetic, and in a Cornell box they are a
//! third of the triangles (the five walls and the light): every shadow ray then tests the two
//! boxes' 24 triangles and their 16 corners instead of 36 triangles and 28 corners. Every width
//! tests the same triangles (the small-set kernels for waves, a tree of the same triangles one
//! ray at a time), so the images stay the same bits at every width. A light at infinity (an
//! environment, a distant light) sends shadow rays out of the scene in every direction,
//! through any wall: then every triangle stays.

use glam::{DVec3, Vec3A};

use super::small_set::SmallSet;
use super::TriangleBvh;
use crate::math::Vec3;

/// Where a scene's light samples can lie, as [`Geometry::limit_shadow_casters`] reads it.
///
/// [`Geometry::limit_shadow_casters`]: super::Geometry::limit_shadow_casters
#[derive(Debug, Clone, Default)]
pub struct LightPoints {
    /// Points whose convex hull holds every point any light's samples can lie at.
    pub hull: Vec<Vec3>,
    /// Whether every light is a surface (its shadow rays end short of it, offset off it).
    pub all_surfaces: bool,
}

/// A triangle in world space (its corners) and its id (instance, primitive).
pub type IdTriangle = ([Vec3A; 3], [u32; 2]);

/// The triangles of a small scene that can block a shadow ray, when some cannot: as a set for
/// waves of rays (where the small-set kernels run) and as a tree for one ray at a time.
#[derive(Debug, Clone)]
pub(super) struct ShadowCasters {
    /// For waves of at least [`crate::lanes::KERNELS_FROM`] lanes (`None` where the kernels
    /// do not run).
    pub set: Option<SmallSet>,
    /// For one ray at a time.
    pub tree: TriangleBvh,
}

impl ShadowCasters {
    /// The casters among `triangles` (the whole scene, as (corners, id) in world space, ids
    /// increasing), given where the light samples lie (`None`: some light is at infinity).
    /// `None` when every triangle may cast a shadow.
    pub fn of(triangles: &[IdTriangle], lights: Option<&LightPoints>) -> Option<ShadowCasters> {
        let lights = lights?;
        let scene: Vec<DVec3> = triangles
            .iter()
            .flat_map(|(corners, _)| corners.map(|c| Vec3::from(c).as_dvec3()))
            .collect();
        let hull: Vec<DVec3> = lights.hull.iter().map(|p| p.as_dvec3()).collect();
        let casters: Vec<&IdTriangle> = triangles
            .iter()
            .filter(|(corners, _)| {
                let plane = PlaneSides::of(corners);
                let bounds_all = plane.bounds(&scene, &hull);
                let holds_lights = lights.all_surfaces && plane.holds(&hull);
                !(bounds_all || holds_lights)
            })
            .collect();
        if casters.len() == triangles.len() {
            return None;
        }
        let corners: Vec<[Vec3A; 3]> = casters.iter().map(|(c, _)| *c).collect();
        let ids: Vec<[u32; 2]> = casters.iter().map(|(_, id)| *id).collect();
        let set = SmallSet::new(corners.len(), |i| corners[i], |i| ids[i]);
        Some(ShadowCasters {
            set,
            tree: TriangleBvh::new(corners, ids),
        })
    }
}

/// A triangle's plane, and on which side of it points lie.
struct PlaneSides {
    /// A corner.
    origin: DVec3,
    /// The (unnormalised) normal: the cross product of two edges.
    normal: DVec3,
}

/// Points within this fraction of |normal| · |p − origin| of the plane count as on it (a
/// scene point may lie there; a light may not): far above the rounding of the f64 arithmetic
/// (~10⁻¹⁶), far below the f32 resolution of the corners (~10⁻⁷).
const ON_PLANE: f64 = 1e-12;

impl PlaneSides {
    fn of(corners: &[Vec3A; 3]) -> PlaneSides {
        let [a, b, c] = corners.map(|c| Vec3::from(c).as_dvec3());
        PlaneSides {
            origin: a,
            normal: (b - a).cross(c - a),
        }
    }

    /// The side of `p`: −1, 0 (on the plane) or 1.
    fn side(&self, p: DVec3) -> i32 {
        let offset = p - self.origin;
        let distance = self.normal.dot(offset);
        if distance.abs() <= ON_PLANE * self.normal.length() * offset.length() {
            0
        } else if distance > 0.0 {
            1
        } else {
            -1
        }
    }

    /// Whether every point of `points` lies on the plane (and the triangle has one).
    fn holds(&self, points: &[DVec3]) -> bool {
        self.normal != DVec3::ZERO && points.iter().all(|&p| self.side(p) == 0)
    }

    /// Whether the plane has every point of `scene` on one closed side and every point of
    /// `lights` strictly on that side (and the triangle has a plane).
    fn bounds(&self, scene: &[DVec3], lights: &[DVec3]) -> bool {
        if self.normal == DVec3::ZERO {
            return false;
        }
        [1, -1].into_iter().any(|side| {
            scene.iter().all(|&p| self.side(p) != -side)
                && lights.iter().all(|&p| self.side(p) == side)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(corners: [[f32; 3]; 4], first_id: u32) -> Vec<IdTriangle> {
        let v = corners.map(Vec3A::from_array);
        vec![
            ([v[0], v[1], v[2]], [0, first_id]),
            ([v[0], v[2], v[3]], [0, first_id + 1]),
        ]
    }

    /// A closed room (floor, ceiling, four walls), a light panel just under the ceiling and a
    /// panel standing on the floor, with the light.
    fn room() -> (Vec<IdTriangle>, LightPoints) {
        let mut tris = Vec::new();
        let (l, h) = (-1.0, 1.0);
        for (k, q) in [
            [[l, l, l], [h, l, l], [h, l, h], [l, l, h]], // floor
            [[l, h, l], [h, h, l], [h, h, h], [l, h, h]], // ceiling
            [[l, l, l], [h, l, l], [h, h, l], [l, h, l]], // back
            [[l, l, h], [h, l, h], [h, h, h], [l, h, h]], // front
            [[l, l, l], [l, h, l], [l, h, h], [l, l, h]], // left
            [[h, l, l], [h, h, l], [h, h, h], [h, l, h]], // right
            [
                [-0.2, 0.99, -0.2],
                [0.2, 0.99, -0.2],
                [0.2, 0.99, 0.2],
                [-0.2, 0.99, 0.2],
            ], // light
            [
                [-0.5, -1.0, 0.0],
                [0.5, -1.0, 0.0],
                [0.5, 0.5, 0.0],
                [-0.5, 0.5, 0.0],
            ], // panel
        ]
        .into_iter()
        .enumerate()
        {
            tris.extend(quad(q, 2 * k as u32));
        }
        let hull = tris[12..14]
            .iter()
            .flat_map(|(c, _)| c.map(Vec3::from))
            .collect();
        let lights = LightPoints {
            hull,
            all_surfaces: true,
        };
        (tris, lights)
    }

    /// The ids of the triangles the casters' tree holds: those it finds on a short segment
    /// through each triangle's centre.
    fn caster_ids(casters: &ShadowCasters, tris: &[IdTriangle]) -> Vec<u32> {
        tris.iter()
            .filter(|(c, _)| {
                let [a, b, c] = *c;
                let centre = Vec3::from((a + b + c) / 3.0);
                let n = Vec3::from(crate::math::cross(b - a, c - a).normalize());
                let ray = super::super::TriRay::new(centre + n * 0.005, n * -0.01);
                casters.tree.occluded(&ray, 0.0, 1.0)
            })
            .map(|(_, id)| id[1])
            .collect()
    }

    #[test]
    fn a_room_casts_no_shadow_from_its_walls_or_its_light() {
        let (tris, lights) = room();
        let casters = ShadowCasters::of(&tris, Some(&lights)).expect("some left out");
        // Only the standing panel's two triangles can block a segment to the light.
        assert_eq!(caster_ids(&casters, &tris), vec![14, 15]);
        assert_eq!(casters.tree.len(), 2);
        if let Some(set) = &casters.set {
            assert_eq!((set.id(0), set.id(1)), ([0, 14], [0, 15]));
        }
    }

    #[test]
    fn walls_between_a_light_and_the_room_cast_shadows() {
        let (tris, mut lights) = room();
        assert!(
            ShadowCasters::of(&tris, None).is_none(),
            "a light at infinity"
        );
        // A point light above the ceiling: the ceiling stands between it and the room, and
        // the light panel's plane no longer holds every light; the floor and the walls still
        // bound everything.
        lights.hull.push(Vec3::new(0.0, 3.0, 0.0));
        lights.all_surfaces = false;
        let casters = ShadowCasters::of(&tris, Some(&lights)).expect("the walls left out");
        assert_eq!(caster_ids(&casters, &tris), vec![2, 3, 12, 13, 14, 15]);
        // A point light on the floor: its shadow rays end on the floor's plane, not short of
        // it, so the floor stays.
        let (tris, mut lights) = room();
        lights.hull.push(Vec3::new(0.0, -1.0, 0.5));
        lights.all_surfaces = false;
        let casters = ShadowCasters::of(&tris, Some(&lights)).expect("the walls left out");
        assert_eq!(caster_ids(&casters, &tris), vec![0, 1, 12, 13, 14, 15]);
        // A point light level with the light panel: the panel's plane holds every light, but
        // the point light's shadow rays end on it, so the panel stays.
        let (tris, mut lights) = room();
        lights.hull.push(Vec3::new(0.5, 0.99, 0.5));
        lights.all_surfaces = false;
        let casters = ShadowCasters::of(&tris, Some(&lights)).expect("the walls left out");
        assert_eq!(caster_ids(&casters, &tris), vec![12, 13, 14, 15]);
        // Lights outside every wall: nothing bounds them and the scene.
        let (tris, mut lights) = room();
        lights.hull.push(Vec3::new(3.0, 3.0, 3.0));
        lights.hull.push(Vec3::new(-3.0, -3.0, -3.0));
        lights.all_surfaces = false;
        assert!(ShadowCasters::of(&tris, Some(&lights)).is_none());
    }
}
