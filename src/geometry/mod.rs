//! Geometry: shapes in object space, instances placing them in the world, and the two-level
//! acceleration structure over instances (a mesh used by several objects is stored once).

pub mod mesh;
mod node8;
pub mod shadow_casters;
pub mod small_set;
pub mod sphere;
pub mod triangle;
pub mod triangle_bvh;
pub mod triangle_source;

use std::sync::Arc;

use glam::{Vec3A, Vec4};

use crate::bvh::{Bvh, TraversalRay};
use crate::lanes::{F32s, Mask, U32s, V3s};
use crate::math::{Aabb, Affine3A, Mat3, Ray, Vec2, Vec3};
pub use mesh::{Mesh, OpacityInputs};
use shadow_casters::{IdTriangle, LightPoints, ShadowCasters};
use small_set::SmallSet;
pub use sphere::{Plane, Sphere};
use triangle::TriHit;
pub use triangle_bvh::{TriRay, TriRayLanes, TriangleBvh};
use triangle_source::TriangleSource;

/// A shape in its own object space.
#[derive(Debug, Clone)]
pub enum Shape {
    /// A sphere.
    Sphere(Sphere),
    /// An infinite plane.
    Plane(Plane),
    /// A triangle mesh (shared between instances).
    Mesh(Arc<Mesh>),
    /// A surface of revolution, intersected exactly ([`crate::lathe`]).
    Lathe(Arc<crate::lathe::Lathe>),
}

/// A shape placed in the world with a material.
#[derive(Debug, Clone)]
pub struct Instance {
    /// The shape.
    pub shape: Shape,
    /// Object → world.
    pub to_world: Affine3A,
    /// World → object.
    pub to_object: Affine3A,
    /// Maps object-space normals to world space (inverse transpose of the linear part).
    pub normal_to_world: Mat3,
    /// Whether `to_world` is the identity (rays need no transforming).
    pub identity: bool,
    /// Material index.
    pub material: u32,
    /// Index of this instance's first area light (one per triangle for meshes), if emissive.
    pub light_base: Option<u32>,
}

impl Instance {
    /// Places `shape` with the object → world map `to_world` (must be invertible).
    pub fn new(shape: Shape, to_world: Affine3A, material: u32) -> Instance {
        let to_object = crate::math::inverse_affine(&to_world);
        let normal_to_world = Mat3::from(to_object.matrix3).transpose();
        let identity = to_world == Affine3A::IDENTITY;
        Instance {
            shape,
            to_world,
            to_object,
            normal_to_world,
            identity,
            material,
            light_base: None,
        }
    }

    /// World-space bounds (infinite for planes).
    pub fn bounds(&self) -> Option<Aabb> {
        let local = match &self.shape {
            Shape::Sphere(s) => s.bounds(),
            Shape::Plane(_) => return None,
            Shape::Mesh(m) => m.bounds(),
            Shape::Lathe(l) => {
                // f64 bounds widened by a hair so f32 rounding never clips the surface.
                let (lo, hi) = l.bounds();
                let pad = 1e-5 * (hi - lo).max_element() + 1e-30;
                Aabb {
                    min: (lo - pad).as_vec3(),
                    max: (hi + pad).as_vec3(),
                }
            }
        };
        Some(if self.identity {
            local
        } else {
            local.transformed(&self.to_world)
        })
    }

    #[inline]
    fn local_ray(&self, ray: &Ray) -> Ray {
        if self.identity {
            *ray
        } else {
            ray.transformed(&self.to_object)
        }
    }

    /// Closest hit within (t_min, t_max); `t` is in units of the world ray's direction.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<RawHit> {
        let r = self.local_ray(ray);
        match &self.shape {
            Shape::Sphere(s) => s.intersect(r.o, r.d, t_min, t_max).map(|t| RawHit {
                t,
                prim: 0,
                coords: [0.0; 2],
            }),
            Shape::Plane(p) => p.intersect(r.o, r.d, t_min, t_max).map(|t| RawHit {
                t,
                prim: 0,
                coords: [0.0; 2],
            }),
            Shape::Mesh(m) => m.intersect(r.o, r.d, t_min, t_max).map(|h| RawHit {
                t: h.t,
                prim: h.prim,
                coords: [h.b1, h.b2],
            }),
            // Solved in f64; the hit keeps (u, v) for the surface record.
            Shape::Lathe(l) => l
                .intersect(r.o.as_dvec3(), r.d.as_dvec3(), t_min as f64, t_max as f64)
                .map(|h| RawHit {
                    t: h.s as f32,
                    prim: h.segment as u32,
                    coords: [h.uv.x as f32, h.uv.y as f32],
                }),
        }
    }

    /// Whether anything of this instance lies within (t_min, t_max).
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        match &self.shape {
            Shape::Mesh(m) => {
                let r = self.local_ray(ray);
                m.occluded(r.o, r.d, t_min, t_max)
            }
            _ => self.intersect(ray, t_min, t_max).is_some(),
        }
    }

    /// The nearest hit within (t_min, t_max) that `accept` takes: found within one traversal
    /// for meshes; other shapes are asked again past each hit they give (at most
    /// [`MAX_REJECTED_HITS`] times, then there is none).
    pub fn intersect_accepted(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut(&RawHit) -> bool,
    ) -> Option<RawHit> {
        if let Shape::Mesh(m) = &self.shape {
            let r = self.local_ray(ray);
            return m.intersect_accepted(r.o, r.d, t_min, t_max, accept);
        }
        let mut from = t_min;
        for _ in 0..MAX_REJECTED_HITS {
            let h = self.intersect(ray, from, t_max)?;
            if accept(&h) {
                return Some(h);
            }
            from = h.t;
        }
        None
    }

    /// Whether a hit within (t_min, t_max) is one `accept` takes (see
    /// [`intersect_accepted`](Self::intersect_accepted)).
    pub fn occluded_accepted(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut(&RawHit) -> bool,
    ) -> bool {
        if let Shape::Mesh(m) = &self.shape {
            let r = self.local_ray(ray);
            return m.occluded_accepted(r.o, r.d, t_min, t_max, accept);
        }
        self.intersect_accepted(ray, t_min, t_max, accept).is_some()
    }

    /// What alpha masks and blending read at a hit (see [`Mesh::opacity_inputs`]); for meshes
    /// without the rest of the surface, which traversals need only for hits they keep.
    pub fn opacity_inputs(&self, ray: &Ray, raw: &RawHit, instance: u32) -> OpacityInputs {
        match &self.shape {
            Shape::Mesh(m) => m.opacity_inputs(&mesh::MeshHit::of_raw(raw)),
            _ => {
                let hit = self.surface(ray, raw, instance);
                OpacityInputs {
                    uv: hit.uv,
                    uv1: hit.uv1,
                    color_alpha: hit.color.w,
                }
            }
        }
    }

    /// The maps that place its surfaces in the world (object → world, and the normals'),
    /// `None` when it is untransformed: what [`mesh::SurfaceLanes::set_transform`] takes.
    #[inline]
    pub fn surface_maps(&self) -> Option<(&Affine3A, &Mat3)> {
        (!self.identity).then_some((&self.to_world, &self.normal_to_world))
    }

    /// The full surface description of a hit.
    pub fn surface(&self, ray: &Ray, raw: &RawHit, instance: u32) -> SurfaceHit {
        let r = self.local_ray(ray);
        let (mut uv1, mut tangent, mut color) = (Vec2::ZERO, Vec4::ZERO, Vec4::ONE);
        let (p, ng, ns, uv) = match &self.shape {
            Shape::Sphere(s) => {
                let (p, n, uv) = s.surface(r.at(raw.t));
                (p, n, n, uv)
            }
            Shape::Plane(pl) => {
                let p = pl.project(r.at(raw.t));
                (p, pl.normal, pl.normal, pl.uv(p))
            }
            Shape::Mesh(m) => {
                let h = mesh::MeshHit::of_raw(raw);
                if m.has_attributes() {
                    (uv1, tangent, color) = m.attributes(&h);
                }
                m.surface(&h)
            }
            Shape::Lathe(l) => {
                let p = r.at(raw.t);
                let [u, v] = raw.coords;
                let n = l.normal_at(v as f64, p.as_dvec3()).as_vec3();
                (p, n, n, Vec2::new(u, v))
            }
        };
        let (p, ng, ns) = if self.identity {
            (p, ng, ns)
        } else {
            if tangent != Vec4::ZERO {
                // Tangents are directions on the surface: they transform as vectors. A mirroring
                // transform flips cross(N, T), so the handedness flips with it.
                let w = if crate::math::determinant(&self.to_world.matrix3) < 0.0 {
                    -tangent.w
                } else {
                    tangent.w
                };
                tangent = self
                    .to_world
                    .transform_vector3(tangent.truncate())
                    .extend(w);
            }
            (
                self.to_world.transform_point3(p),
                (self.normal_to_world * ng).normalize(),
                (self.normal_to_world * ns).normalize(),
            )
        };
        SurfaceHit {
            t: raw.t,
            p,
            ng,
            ns,
            uv,
            uv1,
            tangent,
            color,
            instance,
            prim: raw.prim,
        }
    }
}

/// The minimal record of a hit, enough to compute the surface later.
#[derive(Debug, Clone, Copy)]
pub struct RawHit {
    /// Ray parameter.
    pub t: f32,
    /// Primitive within the shape (triangle index).
    pub prim: u32,
    /// Where on the shape: for triangles the barycentric coordinates of vertices 1 and 2
    /// (vertex 0's is 1 − both); for lathes (u, v) = (θ/2π, profile parameter); unused (0) for
    /// spheres and planes, whose surface is recomputed from the point.
    pub coords: [f32; 2],
}

impl RawHit {
    /// The hit on triangle `id[1]` of a triangle BVH (`id[0]` names its instance or mesh).
    #[inline]
    pub fn of_triangle(id: [u32; 2], h: &TriHit) -> RawHit {
        RawHit {
            t: h.t,
            prim: id[1],
            coords: [h.b1, h.b2],
        }
    }
}

/// What the lanes read of a small set's triangle for its surfaces: its corners and its
/// instance's maps.
#[derive(Debug, Clone)]
struct SmallSlot {
    corners: mesh::CornerData,
    /// Whether the instance is placed by a transform, and then its maps (else the identity's,
    /// which the lanes do not apply).
    transformed: bool,
    maps: (Affine3A, Mat3),
    /// A flat, untextured triangle's normal in world space, computed once
    /// ([`SurfaceLanes::flat_normal`](mesh::SurfaceLanes::flat_normal)).
    flat_normal: Option<Vec3>,
}

/// What the lanes read of a [`SmallSlot`] whose triangle is flat, as 64-byte rows that a
/// wave's sixteen rows turn into lanes in registers. The first holds the corners (9 values),
/// the normal (3), the instance and the primitive (as bits), whether the triangle is flat and
/// whether it is transformed (all bits set, else 0); the second its object → world map (the
/// columns of the linear part, then the translation), read only where some lane's triangle is
/// transformed.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct SlotRow([f32; 16]);

impl SlotRow {
    /// Where the row's fields start.
    const POSITIONS: usize = 0;
    const NORMAL: usize = 9;
    const INSTANCE: usize = 12;
    const PRIM: usize = 13;
    const FLAT: usize = 14;
    const TRANSFORMED: usize = 15;

    /// The rows of `slot`, the set's triangle `id`.
    fn new(slot: &SmallSlot, [instance, prim]: [u32; 2]) -> [SlotRow; 2] {
        let mut row = [0.0; 16];
        let positions = &slot.corners.positions;
        for (c, p) in positions.iter().enumerate() {
            row[Self::POSITIONS + 3 * c..][..3].copy_from_slice(&p.to_array());
        }
        let normal = slot.flat_normal.unwrap_or(Vec3::ZERO);
        row[Self::NORMAL..][..3].copy_from_slice(&normal.to_array());
        row[Self::INSTANCE] = f32::from_bits(instance);
        row[Self::PRIM] = f32::from_bits(prim);
        let all_bits = |b: bool| f32::from_bits(if b { u32::MAX } else { 0 });
        row[Self::FLAT] = all_bits(slot.flat_normal.is_some());
        row[Self::TRANSFORMED] = all_bits(slot.transformed);
        let mut map = [0.0; 16];
        let to_world = &slot.maps.0;
        let m = &to_world.matrix3;
        for (c, column) in [m.x_axis, m.y_axis, m.z_axis, to_world.translation]
            .iter()
            .enumerate()
        {
            map[3 * c..][..3].copy_from_slice(&column.to_array());
        }
        [SlotRow(row), SlotRow(map)]
    }
}

/// [`Geometry::small_surfaces`] for a wave of sixteen lanes whose hits all lie on flat
/// triangles (else it does nothing and returns `false`): the lanes' rows moved into lanes
/// whole ([`transpose_16x16`](crate::lanes::transpose_16x16)), the same values as
/// [`SurfaceLanes::set_flat`](mesh::SurfaceLanes::set_flat) puts lane by lane.
///
/// # Safety
/// The CPU must have AVX-512 F.
///
/// # Panics
/// Unless W is 16.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn flat_rows_in_lanes<const W: usize>(
    rows: &[[SlotRow; 2]],
    h: &small_set::SlotHits<W>,
    lanes: Mask<W>,
    surfaces: &mut mesh::SurfaceLanes<W>,
    found: &mut LaneSurfaces<W>,
) -> bool {
    use std::arch::x86_64::*;
    assert_eq!(W, 16);
    let slots: [&[SlotRow; 2]; 16] = std::array::from_fn(|i| &rows[h.slot[i % W] as usize]);
    let fields = crate::lanes::transpose_16x16(slots.map(|r| &r[0].0));
    let set = |f: usize| {
        let v = _mm512_castps_si512(fields[f]);
        _mm512_test_epi32_mask(v, v)
    };
    let lanes_bits = lanes.bits() as u16;
    if lanes_bits & !set(SlotRow::FLAT) != 0 {
        return false;
    }
    let transformed = lanes_bits & set(SlotRow::TRANSFORMED);
    let maps = (transformed != 0).then(|| crate::lanes::transpose_16x16(slots.map(|r| &r[1].0)));
    surfaces.set_flat_rows(
        lanes_bits,
        (&fields, SlotRow::POSITIONS, SlotRow::NORMAL),
        (h.b1, h.b2),
        (transformed, maps.as_ref()),
    );
    let ids = (fields[SlotRow::INSTANCE], fields[SlotRow::PRIM]);
    found.set_rows(lanes_bits, &h.t, ids);
    true
}

/// A ray's hit on a surface, in world space.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceHit {
    /// Ray parameter.
    pub t: f32,
    /// Hit point.
    pub p: Vec3,
    /// Unit geometric normal; its side is the surface's front.
    pub ng: Vec3,
    /// Unit shading normal (interpolated), on the same side as `ng`.
    pub ns: Vec3,
    /// Texture coordinates.
    pub uv: Vec2,
    /// The second set of texture coordinates (glTF `TEXCOORD_1`); zero where there is none.
    pub uv1: Vec2,
    /// World-space tangent (xyz, along +u of the normal map, not normalised) and bitangent
    /// handedness (w); zero where the mesh has no tangents.
    pub tangent: Vec4,
    /// Linear RGBA vertex colour; white where the mesh has none.
    pub color: Vec4,
    /// Instance index.
    pub instance: u32,
    /// Primitive index within the instance's shape.
    pub prim: u32,
}

/// The segments of a wave's shadow rays, one per lane, as a structure of arrays: lane i looks
/// along `o + t·d` for t in (0, `t_max`) where `live` holds; the other lanes are idle.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct SegmentLanes<const W: usize> {
    /// The lanes with a segment.
    pub live: Mask<W>,
    /// Origins.
    pub o: V3s<W>,
    /// Directions.
    pub d: V3s<W>,
    /// The ends of the segments, in units of `d`.
    pub t_max: F32s<W>,
}

impl<const W: usize> SegmentLanes<W> {
    /// No segment in any lane.
    pub fn new() -> Self {
        SegmentLanes {
            live: Mask::splat(false),
            o: V3s::default(),
            d: V3s::default(),
            t_max: F32s::default(),
        }
    }

    /// The rays `rays[i]` over (0, ∞) (`None` lanes idle).
    pub fn of_rays(rays: &[Option<Ray>; W]) -> Self {
        Self::from_options(&rays.map(|ray| ray.map(|ray| (ray, f32::INFINITY))))
    }

    /// The segments `segments[i]` (`None` lanes idle).
    pub fn from_options(segments: &[Option<(Ray, f32)>; W]) -> Self {
        let mut out = Self::new();
        for (i, segment) in segments.iter().enumerate() {
            if let Some((ray, t_max)) = segment {
                out.set(i, ray, *t_max);
            }
        }
        out
    }

    /// Lane `i` looks along `ray` over (0, `t_max`).
    #[inline]
    pub fn set(&mut self, i: usize, ray: &Ray, t_max: f32) {
        self.live.set(i, true);
        self.o.set(i, ray.o);
        self.d.set(i, ray.d);
        self.t_max[i] = t_max;
    }

    /// Lane `i`'s ray and the end of its segment, if it has one.
    #[inline]
    pub fn get(&self, i: usize) -> Option<(Ray, f32)> {
        self.live
            .lane(i)
            .then(|| (Ray::new(self.o.lane(i), self.d.lane(i)), self.t_max[i]))
    }
}

impl<const W: usize> Default for SegmentLanes<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// What the renderer needs from an acceleration structure.
pub trait Accel: Sync {
    /// The closest hit within (t_min, t_max).
    fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit>;
    /// Whether anything lies within (t_min, t_max).
    fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool;
}

/// Most hits a shape other than a mesh gives one ray before it counts as missed when all of
/// them are rejected (an alpha-masked sphere or lathe: a sphere has two, a lathe a few).
pub const MAX_REJECTED_HITS: u32 = 64;

/// Meshes with at most this many triangles are flattened into the world-space triangle set
/// even when several instances share them (copying them costs less than a second BVH level).
pub const FLATTEN_MAX_SHARED_TRIANGLES: usize = 256;

/// Shared meshes are also copied into the world-space triangle set, smallest total first, as
/// long as their copies (uses × triangles) add up to at most this many triangles (about 110 MB
/// at the peak bytes per triangle of a build): a second BVH level costs every ray that meets
/// one of its instances a transform and a second traversal.
pub const FLATTEN_SHARED_BUDGET: usize = 1 << 20;

/// Which trees of world-space triangles a query of [`Geometry`] looks in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Trees {
    /// The small set's and the rest's.
    Both,
    /// The rest's only (the small set's hits are known from its kernels).
    Flat,
}

/// A world-space triangle whose box has at least this share of the scene's box's surface area
/// is big: it goes to the small set (at most [`small_set::SMALL_SET_MAX`] of them, the biggest
/// first) rather than the tree. A tree cannot bound such triangles tightly (a Cornell box's
/// walls span the scene), so nearly every ray opens the leaves that hold them; a wave tests
/// them in SIMD lanes for less (the Cornell box with a 5k-triangle bunny: walls in the tree
/// cost 1.43 s at 64 spp, in the small set 0.83 s).
pub const BIG_TRIANGLE_SHARE: f32 = 1.0 / 16.0;

/// The big triangles of the world-space set `flat` ((instance, first triangle, mesh) of each
/// flattened instance; `corners` gives triangle i of the set in world space): at most
/// [`small_set::SMALL_SET_MAX`], as indices into the set, increasing. Only meshes of at most
/// that many triangles are looked at, so that large meshes cost nothing here.
fn big_triangles(
    instances: &[Instance],
    flat: &[(usize, usize, &Mesh)],
    corners: impl Fn(usize) -> [Vec3A; 3],
) -> Vec<usize> {
    let scene = flat
        .iter()
        .filter_map(|&(k, _, _)| instances[k].bounds())
        .fold(Aabb::EMPTY, Aabb::union);
    if scene.is_empty() {
        return Vec::new();
    }
    let least = scene.half_area() * BIG_TRIANGLE_SHARE;
    let mut big: Vec<(f32, usize)> = Vec::new();
    for &(_, first, mesh) in flat {
        let count = mesh.data.triangles.len();
        if count > small_set::SMALL_SET_MAX {
            continue;
        }
        for i in first..first + count {
            let [a, b, c] = corners(i);
            let area = Aabb {
                min: a.min(b).min(c).into(),
                max: a.max(b).max(c).into(),
            }
            .half_area();
            if area >= least {
                big.push((area, i));
            }
        }
    }
    big.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    big.truncate(small_set::SMALL_SET_MAX);
    let mut chosen: Vec<usize> = big.into_iter().map(|(_, i)| i).collect();
    chosen.sort_unstable();
    chosen
}

/// All instances of a scene, in two parts:
///
/// - a single BVH over world-space triangles ([`TriangleBvh`]) holding every mesh instance
///   whose mesh is used once (or is small), transformed to world space at build time as pbrt-v4
///   does for non-instanced meshes: rays then need no per-instance transform, and one traversal
///   covers all of them. Waves of rays test the big ones among these triangles (or all of
///   them, when they are the whole scene and few) in SIMD lanes instead ([`SmallSet`]), and
///   walk the BVH of the others only where they can reach it;
/// - a BVH over the remaining bounded instances (spheres, and meshes shared by several
///   instances, each with its own object-space BVH inside: the top level of a two-level
///   hierarchy, so a mesh used twice is stored once), plus the unbounded planes.
///
/// Hits report the instance and the triangle of the original mesh either way, and the surface
/// is computed from the object-space mesh by the barycentrics (an affine map preserves them),
/// so flattening changes only rounding, not results.
#[derive(Debug, Clone)]
pub struct Geometry {
    /// The instances.
    pub instances: Vec<Instance>,
    /// The world-space triangles the small set does not hold.
    flat: TriangleBvh,
    /// Some world-space triangles, tested against a whole wave of rays at once: all of them
    /// when they are the whole scene and few ([`small_set::SMALL_SET_MAX`]), else the big ones
    /// (see [`BIG_TRIANGLE_SHARE`]), which would otherwise lie across a tree's nodes and be
    /// reached by nearly every ray.
    small: Option<SmallSet>,
    /// The small set's triangles as a tree, for queries of one ray at a time.
    small_tree: TriangleBvh,
    /// What the lanes read of each triangle of the small set to compute its surfaces, slot
    /// by slot, when they compute all of them (every triangle lies on a mesh without extra
    /// vertex attributes): a hit then reads its slot's record, not its instance, mesh and
    /// vertices in turn.
    small_slots: Option<Vec<SmallSlot>>,
    /// The slots' rows, slot by slot (empty without `small_slots` or without a flat triangle
    /// among them).
    small_rows: Vec<[SlotRow; 2]>,
    top: Bvh,
    /// Instance index of each primitive of `top`.
    top_instances: Vec<u32>,
    unbounded: Vec<u32>,
    /// The scene's triangles in world space with their ids, when it is nothing else and few
    /// ([`small_set::SMALL_SET_MAX`]); else empty. What [`limit_shadow_casters`] reads.
    ///
    /// [`limit_shadow_casters`]: Geometry::limit_shadow_casters
    few_triangles: Vec<IdTriangle>,
    /// The triangles shadow rays are tested against, when they are fewer than the scene's
    /// ([`Geometry::limit_shadow_casters`]).
    shadow_casters: Option<ShadowCasters>,
}

impl Geometry {
    /// Builds the acceleration structures.
    pub fn new(instances: Vec<Instance>) -> Geometry {
        Geometry::with_flatten_budget(instances, FLATTEN_SHARED_BUDGET)
    }

    /// [`Geometry::new`] copying shared meshes into the world-space set only within `budget`
    /// triangles (see [`FLATTEN_SHARED_BUDGET`]).
    pub fn with_flatten_budget(instances: Vec<Instance>, budget: usize) -> Geometry {
        // How many instances use each mesh.
        let mut uses: std::collections::HashMap<*const Mesh, usize> =
            std::collections::HashMap::new();
        for inst in &instances {
            if let Shape::Mesh(m) = &inst.shape {
                *uses.entry(Arc::as_ptr(m)).or_default() += 1;
            }
        }
        // Shared meshes copied into the world-space set all the same, smallest copies first,
        // while the copies stay within the budget.
        let mut shared: Vec<(*const Mesh, usize)> = uses
            .iter()
            .filter(|&(_, &n)| n > 1)
            .filter_map(|(&m, &n)| {
                instances.iter().find_map(|inst| match &inst.shape {
                    Shape::Mesh(mesh) if Arc::as_ptr(mesh) == m => {
                        Some((m, n * mesh.data.triangles.len()))
                    }
                    _ => None,
                })
            })
            .collect();
        shared.sort_by_key(|&(m, copies)| (copies, m as usize));
        let mut budget = budget;
        let mut copied = std::collections::HashSet::new();
        for (m, copies) in shared {
            if copies <= budget {
                budget -= copies;
                copied.insert(m);
            }
        }
        // The flattened instances: (instance, its first triangle in the world-space set, mesh).
        let mut flat = Vec::new();
        let mut flat_count = 0usize;
        let mut top_instances = Vec::new();
        let mut top_boxes = Vec::new();
        let mut unbounded = Vec::new();
        for (k, inst) in instances.iter().enumerate() {
            if let Shape::Mesh(m) = &inst.shape {
                if uses[&Arc::as_ptr(m)] == 1
                    || m.data.triangles.len() <= FLATTEN_MAX_SHARED_TRIANGLES
                    || copied.contains(&Arc::as_ptr(m))
                {
                    flat.push((k, flat_count, &**m));
                    flat_count += m.data.triangles.len();
                    continue;
                }
                // Shared and large: instanced through its own BVH, built now rather than on
                // the first ray.
                m.bvh();
            }
            match inst.bounds() {
                Some(b) => {
                    top_instances.push(k as u32);
                    top_boxes.push(b);
                }
                None => unbounded.push(k as u32),
            }
        }
        // Triangle i of the set: its instance and its index in the instance's mesh.
        let locate = |i: usize| {
            let (k, first, mesh) = flat[flat.partition_point(|&(_, first, _)| first <= i) - 1];
            (k, (i - first) as u32, mesh)
        };
        // The set's triangles in world space, each instance's mesh read in place: triangle i
        // is `source`'s triangle i, its id (instance, index in the mesh).
        let source = TriangleSource::new(
            flat.iter()
                .map(|&(k, first, mesh)| {
                    let inst = &instances[k];
                    let placed = (!inst.identity).then_some(inst.to_world);
                    mesh.triangle_source_part(first as u32, k as u32, placed)
                })
                .collect(),
        );
        let corners = |i: usize| source.corners(i as u32);
        let id = |i: usize| source.id(i as u32);
        // Whether the scene is its flat triangles alone, and few of them.
        let few_alone = top_instances.is_empty()
            && unbounded.is_empty()
            && flat_count <= small_set::SMALL_SET_MAX;
        let few_triangles = if few_alone {
            (0..flat_count).map(|i| (corners(i), id(i))).collect()
        } else {
            Vec::new()
        };
        // The triangles the small set takes, as indices into the set, increasing: all of them
        // when they are the whole scene and few, else its big triangles (if any).
        let chosen: Vec<usize> = if few_alone && flat_count > 0 {
            (0..flat_count).collect()
        } else {
            big_triangles(&instances, &flat, corners)
        };
        let small = (!chosen.is_empty())
            .then(|| SmallSet::new(chosen.len(), |s| corners(chosen[s]), |s| id(chosen[s])))
            .flatten();
        let chosen = if small.is_some() { chosen } else { Vec::new() };
        let small_slots = small.as_ref().and_then(|_| {
            chosen
                .iter()
                .map(|&i| {
                    let (k, prim, mesh) = locate(i);
                    let inst = &instances[k];
                    (!mesh.has_attributes()).then(|| {
                        let corners = mesh.corner_data(prim);
                        let flat = corners.normals.is_none() && corners.uvs.is_none();
                        let maps = (inst.to_world, inst.normal_to_world);
                        let placed = (!inst.identity).then_some((&maps.0, &maps.1));
                        SmallSlot {
                            flat_normal: flat.then(|| {
                                mesh::SurfaceLanes::<1>::flat_normal(&corners.positions, placed)
                            }),
                            corners,
                            transformed: !inst.identity,
                            maps,
                        }
                    })
                })
                .collect::<Option<Vec<_>>>()
        });
        let small_rows = match (&small, &small_slots) {
            (Some(set), Some(slots)) if slots.iter().any(|s| s.flat_normal.is_some()) => {
                (slots.iter().enumerate())
                    .map(|(s, slot)| SlotRow::new(slot, set.id(s as u32)))
                    .collect()
            }
            _ => Vec::new(),
        };
        // The small set's triangles again as a tree, for queries one ray at a time.
        let small_tree = TriangleBvh::build(
            chosen.len(),
            |s| corners(chosen[s]),
            |s| id(chosen[s]),
            |_, _| {},
        );
        // Triangle j of the tree is triangle `rest(j)` of the set, which skips the chosen: as
        // the chosen increase, so does chosen[c] - c, and j is preceded by those c with
        // chosen[c] - c <= j.
        let shifted: Vec<usize> = chosen.iter().enumerate().map(|(c, &i)| i - c).collect();
        let rest = |j: usize| j + shifted.partition_point(|&x| x <= j);
        let flat_bvh =
            TriangleBvh::from_source(flat_count - chosen.len(), source, |j| rest(j) as u32);
        drop(flat);
        Geometry {
            flat: flat_bvh,
            small_tree,
            small,
            small_slots,
            small_rows,
            top: Bvh::build(&top_boxes),
            top_instances,
            instances,
            unbounded,
            few_triangles,
            shadow_casters: None,
        }
    }

    /// Leaves out of shadow rays' tests ([`shadowed`](Self::shadowed),
    /// [`shadowed_lanes`](Self::shadowed_lanes)) the triangles that can block none, in a scene
    /// of few triangles and nothing else ([`shadow_casters`] says which and why), given where
    /// the lights' samples lie (`None`: some light is at infinity, and every triangle stays).
    pub fn limit_shadow_casters(&mut self, lights: Option<&LightPoints>) {
        self.shadow_casters = ShadowCasters::of(&self.few_triangles, lights);
    }

    /// Bounds of all bounded instances.
    pub fn bounds(&self) -> Aabb {
        let (a, b) = (
            self.flat.bounds().union(self.small_tree.bounds()),
            self.top.bounds(),
        );
        match (a.is_empty(), b.is_empty()) {
            (true, _) => b,
            (_, true) => a,
            _ => a.union(b),
        }
    }

    fn closest(&self, ray: &Ray, t_min: f32, t_max: f32, trees: Trees) -> Option<(u32, RawHit)> {
        self.closest_with(
            (ray, t_min, t_max),
            trees,
            &mut (),
            |bvh, r, t_max, _| bvh.intersect(r, t_min, t_max),
            |inst, _, t_max, _| inst.intersect(ray, t_min, t_max),
        )
    }

    /// The world-space triangle trees `trees` names, those not empty.
    #[inline(always)]
    fn trees(&self, trees: Trees) -> impl Iterator<Item = &TriangleBvh> {
        let small = match trees {
            Trees::Both => Some(&self.small_tree),
            Trees::Flat => None,
        };
        small
            .into_iter()
            .chain([&self.flat])
            .filter(|tree| !tree.is_empty())
    }

    /// The nearest hit over both levels, of `ray` within (t_min, t_max): `flat(bvh, ray, t_max,
    /// state)` queries a tree of world-space triangles (those of `trees`),
    /// `shape(instance, k, t_max, state)` one instance (`state` is what both share, such as an
    /// accept function).
    #[inline(always)]
    fn closest_with<S: ?Sized>(
        &self,
        (ray, t_min, t_max): (&Ray, f32, f32),
        trees: Trees,
        state: &mut S,
        flat: impl Fn(&TriangleBvh, &TriRay, f32, &mut S) -> Option<([u32; 2], TriHit)>,
        shape: impl Fn(&Instance, u32, f32, &mut S) -> Option<RawHit>,
    ) -> Option<(u32, RawHit)> {
        // After a hit at t the bound is a little beyond t, so that hits as near reach `keep`,
        // which breaks the tie by (instance, primitive), whatever the order they are met in.
        let mut best: Option<(u32, RawHit)> = None;
        let mut t_max = t_max;
        let mut tri_ray = None;
        for tree in self.trees(trees) {
            let r = tri_ray.get_or_insert_with(|| TriRay::new(ray.o, ray.d));
            if let Some((id, h)) = flat(tree, r, t_max, state) {
                keep(&mut best, &mut t_max, id[0], RawHit::of_triangle(id, &h));
            }
        }
        for &k in &self.unbounded {
            if let Some(h) = shape(&self.instances[k as usize], k, t_max, state) {
                keep(&mut best, &mut t_max, k, h);
            }
        }
        if !self.top_instances.is_empty() {
            self.top.traverse(
                &TraversalRay::new(ray.o, ray.d),
                t_min,
                &mut t_max,
                |slot, t_max| {
                    let k = self.top_instances[self.top.prims[slot as usize] as usize];
                    if let Some(h) = shape(&self.instances[k as usize], k, *t_max, state) {
                        keep(&mut best, t_max, k, h);
                    }
                    false
                },
            );
        }
        best
    }

    /// Whether anything lies within (t_min, t_max) over both levels, with `trees`, `flat` and
    /// `shape` as in [`closest_with`](Self::closest_with).
    #[inline(always)]
    fn occluded_with<S: ?Sized>(
        &self,
        (ray, t_min, t_max): (&Ray, f32, f32),
        trees: Trees,
        state: &mut S,
        flat: impl Fn(&TriangleBvh, &TriRay, f32, &mut S) -> bool,
        shape: impl Fn(&Instance, u32, f32, &mut S) -> bool,
    ) -> bool {
        let mut tri_ray = None;
        for tree in self.trees(trees) {
            let r = tri_ray.get_or_insert_with(|| TriRay::new(ray.o, ray.d));
            if flat(tree, r, t_max, state) {
                return true;
            }
        }
        for &k in &self.unbounded {
            if shape(&self.instances[k as usize], k, t_max, state) {
                return true;
            }
        }
        if self.top_instances.is_empty() {
            return false;
        }
        let mut t_max = t_max;
        self.top.traverse(
            &TraversalRay::new(ray.o, ray.d),
            t_min,
            &mut t_max,
            |slot, t_max| {
                let k = self.top_instances[self.top.prims[slot as usize] as usize];
                shape(&self.instances[k as usize], k, *t_max, state)
            },
        )
    }
}

impl Geometry {
    /// The closest hits of a wave's rays over (0, ∞) into `hits` (`None` lanes are idle), as
    /// [`Accel::intersect`] finds them one at a time. From [`crate::lanes::KERNELS_FROM`] lanes
    /// on, the surfaces of hits on meshes without extra vertex attributes (the common case) are
    /// computed together in SIMD lanes (`surfaces`: the kernel's working memory), with the
    /// operations of [`Mesh::surface`] and, for transformed instances, of
    /// [`Instance::surface`]'s placing, so with their bits.
    pub fn intersect_lanes<const W: usize>(
        &self,
        rays: &[Option<Ray>; W],
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut mesh::SurfaceLanes<W>,
    ) {
        let mut found = LaneSurfaces::none();
        self.intersect_wave(&SegmentLanes::of_rays(rays), hits, surfaces, &mut found);
        found.fill(hits);
    }

    /// [`intersect_lanes`](Self::intersect_lanes) of the rays of `rays`' live lanes (over
    /// (0, ∞) whatever their `t_max`), keeping the hits whose surfaces are computed in SIMD
    /// lanes as lanes: those go into `found` (and their entries of `hits` are `None`), the
    /// others' into `hits`.
    #[inline(always)]
    pub fn intersect_wave<const W: usize>(
        &self,
        rays: &SegmentLanes<W>,
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut mesh::SurfaceLanes<W>,
        found: &mut LaneSurfaces<W>,
    ) {
        found.in_lanes = Mask::splat(false);
        hits.fill(None);
        match &self.small {
            Some(small) if W >= crate::lanes::KERNELS_FROM => {
                // The small set's hits, for the whole wave at once, then (unless it is the
                // whole scene) whatever lies before them elsewhere.
                let slot_hits = small.closest_slots(rays);
                let from_small = if self.small_is_all() {
                    slot_hits.hit
                } else {
                    self.beyond_small(rays, Some((small, &slot_hits)), hits, surfaces, found)
                };
                self.small_surfaces(small, &slot_hits, from_small, rays, hits, surfaces, found);
            }
            _ => {
                self.beyond_small(rays, None, hits, surfaces, found);
            }
        }
        if found.in_lanes.any() {
            surfaces.run_into(found.in_lanes, &mut found.out);
        }
    }

    /// The closest hits of `rays`' live lanes outside the small set, before the small set's
    /// hit where `small` gives it (the set and its hits): their surfaces' inputs into
    /// `surfaces` and `found`, or their surfaces into `hits`, as
    /// [`intersect_wave`](Self::intersect_wave) keeps them. Returns the lanes whose small-set
    /// hit stands.
    #[inline(always)]
    fn beyond_small<const W: usize>(
        &self,
        rays: &SegmentLanes<W>,
        small: Option<(&SmallSet, &small_set::SlotHits<W>)>,
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut mesh::SurfaceLanes<W>,
        found: &mut LaneSurfaces<W>,
    ) -> Mask<W> {
        let kernels = W >= crate::lanes::KERNELS_FROM;
        let mut from_small = small.map_or(Mask::splat(false), |(_, h)| h.hit);
        // A scene of nothing but world-space triangles: its closest hits beyond the small
        // set's are the flat tree's.
        let flat_only = kernels && self.triangles_only();
        // Each lane's bound: a little beyond the small set's hit, where it has one.
        let bound = |i: usize| match small {
            Some((_, h)) if h.hit.lane(i) => triangle_bvh::tie_bound(h.t[i]),
            _ => f32::INFINITY,
        };
        let further = if flat_only {
            // Only lanes that enter the tree's root can find more there.
            self.flat
                .meets_lanes((&rays.o, &rays.d), F32s::from_fn(bound), rays.live)
        } else {
            rays.live
        };
        let trees = if small.is_some() {
            Trees::Flat
        } else {
            Trees::Both
        };
        let tri_rays = (flat_only && further.any()).then(|| TriRayLanes::new(&rays.o, &rays.d));
        for i in further.iter() {
            let ray = Ray::new(rays.o.lane(i), rays.d.lane(i));
            // A hit found here must come before the small set's, if any.
            let before_small = |t: f32, id: [u32; 2]| match small {
                Some((set, h)) if h.hit.lane(i) => {
                    triangle_bvh::comes_before(t, id, h.t[i], set.id(h.slot[i]))
                }
                _ => true,
            };
            if let Some(tri_rays) = &tri_rays {
                // The hit's corners from the packet it was found in, which holds them as the
                // mesh does where the instance is untransformed.
                let Some((id, h, corners)) =
                    self.flat
                        .intersect_corners(&tri_rays.lane(i), 0.0, bound(i))
                else {
                    continue;
                };
                if !before_small(h.t, id) {
                    continue;
                }
                from_small.set(i, false);
                let (k, raw) = (id[0], RawHit::of_triangle(id, &h));
                let instance = &self.instances[k as usize];
                match &instance.shape {
                    Shape::Mesh(m) if instance.identity && m.has_positions_only() => {
                        let corners = mesh::CornerData {
                            positions: corners,
                            normals: None,
                            uvs: None,
                        };
                        surfaces.set_corners(i, &corners, (h.b1, h.b2));
                        surfaces.set_transform(i, None);
                        found.set(i, raw.t, (k, raw.prim));
                    }
                    _ => self.surface_of(&ray, (k, raw), i, hits, surfaces, found),
                }
                continue;
            }
            if let Some((k, raw)) = self.closest(&ray, 0.0, bound(i), trees) {
                if before_small(raw.t, [k, raw.prim]) {
                    from_small.set(i, false);
                    self.surface_of(&ray, (k, raw), i, hits, surfaces, found);
                }
            }
        }
        from_small
    }

    /// The surfaces of the `lanes`' small-set hits (`slot_hits`): each lane's inputs from its
    /// slot's record where the set has them, else gathered from its mesh.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn small_surfaces<const W: usize>(
        &self,
        small: &SmallSet,
        slot_hits: &small_set::SlotHits<W>,
        lanes: Mask<W>,
        rays: &SegmentLanes<W>,
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut mesh::SurfaceLanes<W>,
        found: &mut LaneSurfaces<W>,
    ) {
        let h = slot_hits;
        match &self.small_slots {
            Some(slots) => {
                #[cfg(target_arch = "x86_64")]
                if W == 16 && !self.small_rows.is_empty() && crate::lanes::has_avx512() {
                    // SAFETY: the CPU has AVX-512 F.
                    if unsafe { flat_rows_in_lanes(&self.small_rows, h, lanes, surfaces, found) } {
                        return;
                    }
                }
                for i in lanes.iter() {
                    let slot = &slots[h.slot[i] as usize];
                    let barycentrics = (h.b1[i], h.b2[i]);
                    match slot.flat_normal {
                        Some(normal) => {
                            let to_world = slot.transformed.then_some(&slot.maps.0);
                            let positions = &slot.corners.positions;
                            surfaces.set_flat(i, positions, barycentrics, normal, to_world);
                        }
                        None => {
                            surfaces.set_corners(i, &slot.corners, barycentrics);
                            surfaces.set_maps(i, slot.transformed, (&slot.maps.0, &slot.maps.1));
                        }
                    }
                    let [k, prim] = small.id(h.slot[i]);
                    found.set(i, h.t[i], (k, prim));
                }
            }
            None => {
                for i in lanes.iter() {
                    let ray = Ray::new(rays.o.lane(i), rays.d.lane(i));
                    let id = small.id(h.slot[i]);
                    let raw = (id[0], RawHit::of_triangle(id, &h.tri_hit(i)));
                    self.surface_of(&ray, raw, i, hits, surfaces, found);
                }
            }
        }
    }

    /// Whether the small set holds every shape of the scene.
    #[inline]
    fn small_is_all(&self) -> bool {
        self.flat.is_empty() && self.triangles_only()
    }

    /// Whether the scene is nothing but world-space triangles (no shared meshes, spheres,
    /// lathes or planes): the small set and the flat tree.
    #[inline]
    fn triangles_only(&self) -> bool {
        self.top_instances.is_empty() && self.unbounded.is_empty()
    }

    /// Lane `i`'s hit `(k, raw)` (on instance k) of `ray`: its surface's inputs into
    /// `surfaces` and the hit into `found` where the lanes compute it (a mesh without extra
    /// vertex attributes), else its surface into `hits`.
    #[inline]
    fn surface_of<const W: usize>(
        &self,
        ray: &Ray,
        (k, raw): (u32, RawHit),
        i: usize,
        hits: &mut [Option<SurfaceHit>; W],
        surfaces: &mut mesh::SurfaceLanes<W>,
        found: &mut LaneSurfaces<W>,
    ) {
        let instance = &self.instances[k as usize];
        match &instance.shape {
            Shape::Mesh(m) if W >= crate::lanes::KERNELS_FROM && !m.has_attributes() => {
                m.gather_surface(surfaces, i, &mesh::MeshHit::of_raw(&raw));
                surfaces.set_transform(i, instance.surface_maps());
                found.set(i, raw.t, (k, raw.prim));
            }
            _ => hits[i] = Some(instance.surface(ray, &raw, k)),
        }
    }
}

/// The hits of a wave whose surfaces were computed in SIMD lanes
/// ([`Geometry::intersect_wave`]), as lanes: each on a mesh without extra vertex attributes.
#[repr(C, align(64))]
pub struct LaneSurfaces<const W: usize> {
    /// The lanes with such a hit (the others' values mean nothing).
    pub in_lanes: Mask<W>,
    /// The hits' distances.
    pub t: F32s<W>,
    /// Their instances.
    pub instance: U32s<W>,
    /// Their triangles in their instances' meshes.
    pub prim: U32s<W>,
    /// Their surfaces.
    pub out: mesh::SurfacesOut<W>,
}

impl<const W: usize> LaneSurfaces<W> {
    /// No lane.
    pub fn none() -> Self {
        LaneSurfaces {
            in_lanes: Mask::splat(false),
            t: F32s::default(),
            instance: U32s::default(),
            prim: U32s::default(),
            out: mesh::SurfacesOut::default(),
        }
    }

    /// Makes lane `i` a hit at distance `t` on triangle `prim` of instance `instance` (its
    /// surface is the kernel's lane `i`).
    #[inline]
    pub fn set(&mut self, i: usize, t: f32, (instance, prim): (u32, u32)) {
        self.in_lanes.set(i, true);
        self.t[i] = t;
        (self.instance[i], self.prim[i]) = (instance, prim);
    }

    /// [`set`](Self::set) in the `lanes` (bits) of a wave of sixteen at once: their distances
    /// from `t`, their instances and triangles the bits of `instance` and `prim`.
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    ///
    /// # Panics
    /// Unless W is 16.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn set_rows(
        &mut self,
        lanes: u16,
        t: &F32s<W>,
        (instance, prim): (std::arch::x86_64::__m512, std::arch::x86_64::__m512),
    ) {
        use std::arch::x86_64::{_mm512_loadu_ps, _mm512_mask_storeu_ps};
        assert_eq!(W, 16);
        self.in_lanes = self.in_lanes | Mask::from_bits(u64::from(lanes));
        crate::lanes::store_lanes_16(&mut self.t, lanes, _mm512_loadu_ps(t.0.as_ptr()));
        for (ids, v) in [(&mut self.instance, instance), (&mut self.prim, prim)] {
            // SAFETY: `ids` holds 16 u32 (W = 16), stored with their bits.
            _mm512_mask_storeu_ps(ids.0.as_mut_ptr().cast(), lanes, v);
        }
    }

    /// Lane `i`'s hit (`i` in [`in_lanes`](Self::in_lanes)).
    #[inline]
    pub fn hit(&self, i: usize) -> SurfaceHit {
        lane_surface(&self.out, i, self.t[i], (self.instance[i], self.prim[i]))
    }

    /// Lane `i`'s hit where it is one of these lanes.
    #[inline]
    pub fn get(&self, i: usize) -> Option<SurfaceHit> {
        self.in_lanes.lane(i).then(|| self.hit(i))
    }

    /// Puts these lanes' hits into `hits`.
    pub fn fill(&self, hits: &mut [Option<SurfaceHit>; W]) {
        if !self.in_lanes.any() {
            return;
        }
        for (i, hit) in hits.iter_mut().enumerate() {
            if self.in_lanes.lane(i) {
                *hit = Some(self.hit(i));
            }
        }
    }
}

/// Lane `i` of the surface kernel's results as the hit at distance `t` on triangle `prim` of
/// instance `instance` (a mesh without extra vertex attributes: no second texture
/// coordinates, tangent or colour).
#[inline]
fn lane_surface<const W: usize>(
    out: &mesh::SurfacesOut<W>,
    i: usize,
    t: f32,
    (instance, prim): (u32, u32),
) -> SurfaceHit {
    SurfaceHit {
        t,
        p: out.p.lane(i),
        ng: out.ng.lane(i),
        ns: out.ns.lane(i),
        uv: Vec2::new(out.uv.0[i], out.uv.1[i]),
        uv1: Vec2::ZERO,
        tangent: Vec4::ZERO,
        color: Vec4::ONE,
        instance,
        prim,
    }
}

impl Geometry {
    /// Whether anything lies within (t_min, t_max), the world-space triangles looked for in
    /// `trees`.
    fn occluded_in(&self, ray: &Ray, t_min: f32, t_max: f32, trees: Trees) -> bool {
        self.occluded_with(
            (ray, t_min, t_max),
            trees,
            &mut (),
            |bvh, r, t_max, _| bvh.occluded(r, t_min, t_max),
            |inst, _, t_max, _| inst.occluded(ray, t_min, t_max),
        )
    }

    /// Whether something blocks each of a wave's segments (over (0, `t_max`); idle lanes report
    /// `false`), as [`Accel::occluded`] finds it.
    #[inline(always)]
    pub fn occluded_lanes<const W: usize>(&self, segments: &SegmentLanes<W>) -> [bool; W] {
        match &self.small {
            Some(small) if W >= crate::lanes::KERNELS_FROM => {
                let mut blocked = small.occluded_lanes(segments);
                if !self.small_is_all() {
                    let open = segments.live & !Mask::from_bools(&blocked);
                    if self.triangles_only() {
                        // The tree alone, and only for lanes that enter its root.
                        let (o, d, t_max) = (&segments.o, &segments.d, segments.t_max);
                        let entering = self.flat.meets_lanes((o, d), t_max, open);
                        if entering.any() {
                            let rays = TriRayLanes::new(o, d);
                            for i in entering.iter() {
                                blocked[i] = self.flat.occluded(&rays.lane(i), 0.0, t_max[i]);
                            }
                        }
                        return blocked;
                    }
                    for i in open.iter() {
                        let ray = Ray::new(segments.o.lane(i), segments.d.lane(i));
                        blocked[i] = self.occluded_in(&ray, 0.0, segments.t_max[i], Trees::Flat);
                    }
                }
                blocked
            }
            _ => std::array::from_fn(|i| {
                segments
                    .get(i)
                    .is_some_and(|(ray, t_max)| self.occluded(&ray, 0.0, t_max))
            }),
        }
    }

    /// How many triangles shadow rays are tested against, when fewer than the scene's
    /// ([`limit_shadow_casters`](Self::limit_shadow_casters)).
    pub fn shadow_caster_count(&self) -> Option<usize> {
        self.shadow_casters.as_ref().map(|c| c.tree.len())
    }

    /// Whether something blocks the shadow ray `ray` (a segment from a point of the scene
    /// towards a light sample, over (0, `t_max`)): [`Accel::occluded`] over the triangles
    /// that can block one ([`limit_shadow_casters`](Self::limit_shadow_casters)), the same
    /// answer for every such segment.
    #[inline]
    pub fn shadowed(&self, ray: &Ray, t_max: f32) -> bool {
        match &self.shadow_casters {
            Some(casters) => casters
                .tree
                .occluded(&TriRay::new(ray.o, ray.d), 0.0, t_max),
            None => self.occluded(ray, 0.0, t_max),
        }
    }

    /// [`shadowed`](Self::shadowed) for each of a wave's shadow rays (idle lanes report
    /// `false`), as [`occluded_lanes`](Self::occluded_lanes) tests segments.
    #[inline(always)]
    pub fn shadowed_lanes<const W: usize>(&self, segments: &SegmentLanes<W>) -> [bool; W] {
        match &self.shadow_casters {
            Some(ShadowCasters { set: Some(set), .. }) if W >= crate::lanes::KERNELS_FROM => {
                set.occluded_lanes(segments)
            }
            Some(_) => std::array::from_fn(|i| {
                segments
                    .get(i)
                    .is_some_and(|(ray, t_max)| self.shadowed(&ray, t_max))
            }),
            None => self.occluded_lanes(segments),
        }
    }
}

impl Geometry {
    /// The nearest hit within (t_min, t_max) that `accept` (given the instance and the hit)
    /// takes, looked for within one traversal of each level.
    pub fn intersect_accepted(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut(u32, &RawHit) -> bool,
    ) -> Option<(u32, RawHit)> {
        self.closest_with(
            (ray, t_min, t_max),
            Trees::Both,
            accept,
            |bvh, r, t_max, accept| {
                bvh.intersect_accepted(r, t_min, t_max, &mut |id, h| {
                    accept(id[0], &RawHit::of_triangle(id, h))
                })
            },
            |inst, k, t_max, accept| {
                inst.intersect_accepted(ray, t_min, t_max, &mut |h| accept(k, h))
            },
        )
    }

    /// Whether a hit within (t_min, t_max) is one `accept` takes.
    pub fn occluded_accepted(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        accept: &mut dyn FnMut(u32, &RawHit) -> bool,
    ) -> bool {
        self.occluded_with(
            (ray, t_min, t_max),
            Trees::Both,
            accept,
            |bvh, r, t_max, accept| {
                bvh.occluded_accepted(r, t_min, t_max, &mut |id, h| {
                    accept(id[0], &RawHit::of_triangle(id, h))
                })
            },
            |inst, k, t_max, accept| {
                inst.occluded_accepted(ray, t_min, t_max, &mut |h| accept(k, h))
            },
        )
    }
}

impl Accel for Geometry {
    fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        self.closest(ray, t_min, t_max, Trees::Both)
            .map(|(k, h)| self.instances[k as usize].surface(ray, &h, k))
    }

    fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.occluded_in(ray, t_min, t_max, Trees::Both)
    }
}

/// Tests every instance for every ray: slow, obviously right, the oracle for [`Geometry`].
pub struct BruteForce<'a>(pub &'a [Instance]);

/// Makes hit `h` on instance `k` the closest one when it comes before `best`: nearer, or as
/// near on a lower (instance, primitive). Equally near hits are thereby ordered by the scene
/// alone, never by the order a traversal meets them, so an image does not depend on how the
/// trees are built or walked. `t_max` becomes [`triangle_bvh::tie_bound`] of the best distance,
/// so that later queries still report hits as near.
#[inline(always)]
fn keep(best: &mut Option<(u32, RawHit)>, t_max: &mut f32, k: u32, h: RawHit) {
    let precedes = best
        .as_ref()
        .is_none_or(|(bk, bh)| triangle_bvh::comes_before(h.t, (k, h.prim), bh.t, (*bk, bh.prim)));
    if precedes {
        *t_max = triangle_bvh::tie_bound(h.t);
        *best = Some((k, h));
    }
}

impl Accel for BruteForce<'_> {
    fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<SurfaceHit> {
        let mut best: Option<(u32, RawHit)> = None;
        let mut t_max = t_max;
        for (k, inst) in self.0.iter().enumerate() {
            if let Some(h) = inst.intersect(ray, t_min, t_max) {
                keep(&mut best, &mut t_max, k as u32, h);
            }
        }
        best.map(|(k, h)| self.0[k as usize].surface(ray, &h, k))
    }

    fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.0.iter().any(|i| i.occluded(ray, t_min, t_max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::sampler::test_lcg as lcg;

    #[test]
    fn two_level_bvh_agrees_with_brute_force_under_transforms() {
        let mut s = 11u64;
        let cube_pos: Vec<Vec3> = (0..8)
            .map(|i| {
                Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * 2.0 - 1.0
            })
            .collect();
        let cube_tris = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        let (cube, _) = Mesh::from_triangles(cube_pos, cube_tris);
        let cube = Arc::new(cube);
        let mut instances = Vec::new();
        for i in 0..60 {
            let t = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 20.0 - 10.0;
            let scale = Vec3::new(0.2 + lcg(&mut s), 0.2 + lcg(&mut s), 0.2 + lcg(&mut s));
            let rot = glam::Quat::from_axis_angle(
                Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s) + 0.1).normalize(),
                lcg(&mut s) * 6.0,
            );
            let m = Affine3A::from_scale_rotation_translation(scale, rot, t);
            let shape = if i % 2 == 0 {
                Shape::Mesh(cube.clone())
            } else {
                Shape::Sphere(Sphere {
                    center: Vec3::ZERO,
                    radius: 1.0,
                })
            };
            instances.push(Instance::new(shape, m, 0));
        }
        instances.push(Instance::new(
            Shape::Plane(Plane {
                normal: Vec3::Y,
                offset: -12.0,
            }),
            Affine3A::IDENTITY,
            0,
        ));
        let geo = Geometry::new(instances.clone());
        agree_with_brute_force(&geo, &instances, &mut s, 4000, 30.0, |a, b| {
            assert!((a.p - b.p).length() < 1e-4 && (a.ng - b.ng).length() < 1e-4);
            // Non-uniformly scaled spheres: the world normal is perpendicular to the surface,
            // so it matches the gradient of the ellipsoid's implicit function.
            let inst = &instances[a.instance as usize];
            if let Shape::Sphere(_) = inst.shape {
                let q = inst.to_object.transform_point3(a.p);
                assert!((q.length() - 1.0).abs() < 1e-4);
                let grad = (Mat3::from(inst.to_object.matrix3).transpose() * q).normalize();
                assert!((grad - a.ng).length() < 1e-4);
            }
        });
    }

    /// Casts `n` random rays (origins in the cube of side `span` around the origin) at `geo`
    /// and at the brute-force oracle over `instances`: both must report the same closest
    /// (instance, triangle) and the same any-hit answer, and a segment ending just before the
    /// hit is unoccluded. `both_hit` checks each pair of hits further. Returns the number of hits.
    fn agree_with_brute_force(
        geo: &Geometry,
        instances: &[Instance],
        s: &mut u64,
        n: usize,
        span: f32,
        mut both_hit: impl FnMut(&SurfaceHit, &SurfaceHit),
    ) -> u32 {
        let brute = BruteForce(instances);
        let mut hits = 0;
        for _ in 0..n {
            let o = Vec3::new(lcg(s), lcg(s), lcg(s)) * span - span / 2.0;
            let d = Vec3::new(lcg(s) - 0.5, lcg(s) - 0.5, lcg(s) - 0.5).normalize();
            let ray = Ray::new(o, d);
            let a = geo.intersect(&ray, 0.0, f32::INFINITY);
            let b = brute.intersect(&ray, 0.0, f32::INFINITY);
            assert_eq!(
                a.map(|h| (h.instance, h.prim)),
                b.map(|h| (h.instance, h.prim))
            );
            if let (Some(a), Some(b)) = (&a, &b) {
                hits += 1;
                both_hit(a, b);
            }
            assert_eq!(geo.occluded(&ray, 0.0, f32::INFINITY), b.is_some());
            if let Some(b) = b {
                assert!(!geo.occluded(&ray, 0.0, b.t * 0.999));
            }
        }
        hits
    }
    /// Large meshes shared by several instances stay instanced (two-level path), used-once
    /// meshes are flattened to world space; both must agree with the brute-force oracle.
    #[test]
    fn instanced_and_flattened_meshes_agree_with_brute_force() {
        let mut s = 21u64;
        let (pos, tris) = mesh::icosphere(3); // 1280 triangles: above the flattening limit
        assert!(tris.len() > FLATTEN_MAX_SHARED_TRIANGLES);
        let shared = Arc::new(Mesh::from_triangles(pos.clone(), tris.clone()).0);
        let mut instances = Vec::new();
        for i in 0..12 {
            let t = Vec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 16.0 - 8.0;
            let scale = Vec3::new(0.5 + lcg(&mut s), 0.5 + lcg(&mut s), 0.5 + lcg(&mut s));
            let rot = glam::Quat::from_axis_angle(
                Vec3::new(lcg(&mut s), lcg(&mut s) + 0.1, lcg(&mut s)).normalize(),
                lcg(&mut s) * 6.0,
            );
            let m = Affine3A::from_scale_rotation_translation(scale, rot, t);
            let mesh = if i % 3 == 0 {
                Arc::new(Mesh::from_triangles(pos.clone(), tris.clone()).0)
            } else {
                shared.clone()
            };
            instances.push(Instance::new(Shape::Mesh(mesh), m, 0));
        }
        // Without a budget for copies the shared mesh is instanced; with the default one it is
        // copied as well (12 × 1,280 triangles).
        for (budget, flat, top) in [(0, 4, 8), (FLATTEN_SHARED_BUDGET, 12, 0)] {
            let geo = Geometry::with_flatten_budget(instances.clone(), budget);
            assert_eq!(geo.flat.len(), flat * tris.len());
            assert_eq!(geo.top_instances.len(), top);
            let hits = agree_with_brute_force(&geo, &instances, &mut s, 3000, 24.0, |a, b| {
                assert!(
                    (a.t - b.t).abs() < 1e-4 * b.t.max(1.0)
                        && (a.p - b.p).length() < 1e-4
                        && (a.ng - b.ng).length() < 1e-4
                );
            });
            assert!(hits > 50, "too few hits to test anything: {hits}");
        }
    }

    #[test]
    fn icosphere_counts_and_orientation() {
        for n in 0..4 {
            let (pos, tris) = mesh::icosphere(n);
            assert_eq!(tris.len(), 20 * 4usize.pow(n));
            assert_eq!(pos.len(), 10 * 4usize.pow(n) + 2);
            for t in &tris {
                let [a, b, c] = t.map(|i| pos[i as usize]);
                assert!(
                    (b - a).cross(c - a).dot(a + b + c) > 0.0,
                    "faces point outwards"
                );
            }
        }
    }

    /// Equally near hits go to the lowest (instance, primitive), whatever the order the trees
    /// meet them in: a quad repeated in eight coincident instances (flattened to world space,
    /// several leaf packets) and, in a ninth, instanced mesh, one triangle repeated five times,
    /// all hit by rays from every side. Traversal order alone (front to back by box, lanes in
    /// build order) would give various winners.
    #[test]
    fn ties_go_to_the_lowest_instance_and_primitive() {
        let quad = |z: f32| {
            let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            Mesh::from_triangles(
                corners.iter().map(|&(x, y)| Vec3::new(x, y, z)).collect(),
                vec![[0, 1, 2], [0, 2, 3]],
            )
            .0
        };
        let mut instances: Vec<Instance> = (0..8)
            .map(|_| Instance::new(Shape::Mesh(Arc::new(quad(0.0))), Affine3A::IDENTITY, 0))
            .collect();
        let repeated = Mesh::from_triangles(
            vec![
                Vec3::new(-1.0, -1.0, 5.0),
                Vec3::new(1.0, -1.0, 5.0),
                Vec3::new(0.0, 1.0, 5.0),
            ],
            vec![[0, 1, 2]; 5],
        )
        .0;
        assert_eq!(repeated.data.triangles.len(), 5);
        let shared = Arc::new(repeated);
        // Shared by two instances (the second far away), so it stays instanced.
        instances.push(Instance::new(
            Shape::Mesh(shared.clone()),
            Affine3A::IDENTITY,
            0,
        ));
        instances.push(Instance::new(
            Shape::Mesh(shared),
            Affine3A::from_translation(Vec3::new(100.0, 0.0, 0.0)),
            0,
        ));
        let geo = Geometry::new(instances.clone());
        let brute = BruteForce(&instances);
        let mut s = 5u64;
        for i in 0..2000 {
            let (z, plane) = if i % 2 == 0 { (0.0, 0) } else { (5.0, 8) };
            // Inside the quad, and inside the triangle (0, 1) … (±1, −1) too.
            let target = Vec3::new(lcg(&mut s) * 0.8 - 0.4, lcg(&mut s) * 0.8 - 0.8, z);
            let d = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5);
            let d = Vec3::new(d.x, d.y, d.z.signum() * (d.z.abs() + 0.2)).normalize();
            let ray = Ray::new(target - d * 3.0, d);
            let hit = geo.intersect(&ray, 0.0, f32::INFINITY);
            let hit = hit.unwrap_or_else(|| panic!("ray {i} misses"));
            assert_eq!(hit.instance, plane, "ray {i}");
            if plane == 8 {
                assert_eq!(hit.prim, 0, "ray {i}");
            }
            let oracle = brute
                .intersect(&ray, 0.0, f32::INFINITY)
                .map(|h| (h.instance, h.prim));
            assert_eq!(oracle, Some((hit.instance, hit.prim)), "ray {i}");
        }
    }

    /// A wave's closest hits and shadow segments, found together (the small set's kernels for
    /// few triangles, the BVH per lane for more; the surfaces in lanes, placed by their
    /// instances' transforms), are one lane at a time's, bit for bit.
    #[test]
    fn waves_of_rays_find_the_hits_and_surfaces_of_single_rays() {
        let mut s = 11u64;
        let v3 = |s: &mut u64| Vec3::new(lcg(s), lcg(s), lcg(s)) * 2.0 - 1.0;
        // A smooth, textured patch: vertex normals and texture coordinates.
        let positions: Vec<Vec3> = (0..12).map(|_| v3(&mut s)).collect();
        let normals: Vec<Vec3> = positions.iter().map(|p| p.normalize()).collect();
        let uvs: Vec<Vec2> = positions
            .iter()
            .map(|p| Vec2::new(p.x, p.y * p.z))
            .collect();
        let triangles: Vec<[u32; 3]> = (0..8).map(|i| [i, (i + 1) % 12, (i + 5) % 12]).collect();
        let (patch, _) = Mesh::new(mesh::MeshData {
            positions: Arc::new(positions),
            triangles: Arc::new(triangles),
            normals: Some(Arc::new(normals)),
            uvs: Some(Arc::new(uvs)),
            uvs1: None,
            tangents: None,
            colors: None,
        });
        let patch = Arc::new(patch);
        let place = |s: &mut u64, mirror: bool| {
            let scale = Vec3::new(0.3 + lcg(s), 0.3 + lcg(s), 0.3 + lcg(s));
            let scale = if mirror {
                scale * Vec3::new(-1.0, 1.0, 1.0)
            } else {
                scale
            };
            let axis = Vec3::new(lcg(s), lcg(s), lcg(s) + 0.1).normalize();
            let rot = glam::Quat::from_axis_angle(axis, lcg(s) * 6.0);
            Affine3A::from_scale_rotation_translation(
                scale,
                rot,
                Vec3::new(lcg(s), lcg(s), lcg(s)) * 4.0 - 2.0,
            )
        };
        for copies in [4, 40] {
            let instances: Vec<Instance> = (0..copies)
                .map(|k| {
                    let to_world = match k % 3 {
                        0 => Affine3A::IDENTITY,
                        1 => place(&mut s, false),
                        _ => place(&mut s, true),
                    };
                    Instance::new(Shape::Mesh(patch.clone()), to_world, 0)
                })
                .collect();
            let geo = Geometry::new(instances);
            // 32 triangles go to the small set, 320 to the BVH.
            assert_eq!(geo.small.is_some(), copies * 8 <= small_set::SMALL_SET_MAX);
            let bits = |h: &SurfaceHit| {
                let v = |v: Vec3| v.to_array().map(f32::to_bits);
                (
                    h.instance,
                    h.prim,
                    h.t.to_bits(),
                    v(h.p),
                    v(h.ng),
                    v(h.ns),
                    h.uv.to_array().map(f32::to_bits),
                )
            };
            for _ in 0..400 {
                let rays: [Option<Ray>; 16] = std::array::from_fn(|i| {
                    (i != 3).then(|| Ray::new(v3(&mut s) * 3.0, v3(&mut s).normalize()))
                });
                check_wave::<16, _>(&geo, &rays, bits);
                check_wave::<8, _>(&geo, &std::array::from_fn(|i| rays[i]), bits);
                check_wave::<4, _>(&geo, &std::array::from_fn(|i| rays[i]), bits);
            }
        }
    }

    /// A wave's closest hits (`bits` of each) and the any-hit answers for segments ending just
    /// before and just after them, against the same rays' single queries.
    fn check_wave<const W: usize, B: PartialEq + std::fmt::Debug>(
        geo: &Geometry,
        rays: &[Option<Ray>; W],
        bits: impl Fn(&SurfaceHit) -> B,
    ) {
        let mut hits = [None; W];
        let mut surfaces = mesh::SurfaceLanes::<W>::new();
        geo.intersect_lanes(rays, &mut hits, &mut surfaces);
        let mut segments = [None; W];
        for (i, ray) in rays.iter().enumerate() {
            let single = ray.and_then(|r| geo.intersect(&r, 0.0, f32::INFINITY));
            assert_eq!(
                hits[i].as_ref().map(&bits),
                single.as_ref().map(&bits),
                "lane {i}"
            );
            // Segments ending just before and just after the hit.
            let end = single.map_or(5.0, |h| h.t * if i % 2 == 0 { 0.999 } else { 1.001 });
            segments[i] = ray.map(|r| (r, end));
        }
        let blocked = geo.occluded_lanes(&SegmentLanes::from_options(&segments));
        for (i, segment) in segments.iter().enumerate() {
            let single = segment.is_some_and(|(r, t_max)| geo.occluded(&r, 0.0, t_max));
            assert_eq!(blocked[i], single, "lane {i}");
        }
    }

    /// A room of big wall quads around a 1,280-triangle sphere of triangles and a small
    /// light: the walls go to the small set, the rest to the tree, and every query, one ray
    /// at a time or a wave at a time, finds the brute-force oracle's hits; coplanar
    /// triangles on both sides of the split tie to the lowest (instance, primitive).
    #[test]
    fn big_triangles_go_to_the_small_set_and_queries_agree() {
        let quad = |corners: [Vec3; 4]| {
            Arc::new(Mesh::from_triangles(corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]]).0)
        };
        let v = Vec3::new;
        let walls = [
            [
                v(-1., -1., -1.),
                v(-1., -1., 1.),
                v(1., -1., 1.),
                v(1., -1., -1.),
            ],
            [
                v(-1., 1., -1.),
                v(1., 1., -1.),
                v(1., 1., 1.),
                v(-1., 1., 1.),
            ],
            [
                v(-1., -1., -1.),
                v(1., -1., -1.),
                v(1., 1., -1.),
                v(-1., 1., -1.),
            ],
            [
                v(-1., -1., -1.),
                v(-1., 1., -1.),
                v(-1., 1., 1.),
                v(-1., -1., 1.),
            ],
            [
                v(1., -1., -1.),
                v(1., -1., 1.),
                v(1., 1., 1.),
                v(1., 1., -1.),
            ],
        ];
        let (pos, tris) = mesh::icosphere(3);
        let ball = Arc::new(Mesh::from_triangles(pos, tris).0);
        let light = quad([
            v(-0.2, 0.99, -0.2),
            v(0.2, 0.99, -0.2),
            v(0.2, 0.99, 0.2),
            v(-0.2, 0.99, 0.2),
        ]);
        // A patch lying in the floor's plane, before the floor (instance 0) and after it.
        let patch = quad([
            v(-0.3, -1., -0.3),
            v(-0.3, -1., 0.3),
            v(0.3, -1., 0.3),
            v(0.3, -1., -0.3),
        ]);
        let mesh_instance =
            |m: &Arc<Mesh>, to_world| Instance::new(Shape::Mesh(m.clone()), to_world, 0);
        let ball_place = Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.4),
            glam::Quat::IDENTITY,
            v(0.2, -0.5, 0.1),
        );
        let mut s = 5u64;
        for with_sphere in [false, true] {
            let mut instances = vec![mesh_instance(&patch, Affine3A::IDENTITY)];
            instances.extend(
                walls
                    .iter()
                    .map(|&w| mesh_instance(&quad(w), Affine3A::IDENTITY)),
            );
            instances.push(mesh_instance(&light, Affine3A::IDENTITY));
            instances.push(mesh_instance(&ball, ball_place));
            instances.push(mesh_instance(&patch, Affine3A::IDENTITY));
            if with_sphere {
                let sphere = sphere::Sphere {
                    center: v(-0.5, 0.3, -0.4),
                    radius: 0.2,
                };
                instances.push(Instance::new(Shape::Sphere(sphere), Affine3A::IDENTITY, 0));
            }
            let geo = Geometry::new(instances.clone());
            // The ten wall triangles (each box a sixth of the room's area or more); the light's,
            // the patches' and the ball's are too small.
            assert_eq!(geo.small_tree.len(), 10);
            assert!(geo.small.is_some());
            assert_eq!(geo.flat.len(), 2 + 2 + 1280 + 2);
            let hits = agree_with_brute_force(&geo, &instances, &mut s, 3000, 1.9, |a, b| {
                // The ball is tested in world space here, in object space by the oracle.
                assert!((a.t - b.t).abs() <= 1e-5 * b.t.max(1.0));
            });
            assert!(hits > 2500, "too few hits to test anything: {hits}");
            // Rays down onto the floor where the patches lie on it: the first patch wins.
            for k in 0..50 {
                let o = v(0.6 * lcg(&mut s) - 0.3, 0.5, 0.6 * lcg(&mut s) - 0.3);
                let ray = Ray::new(o, v(0.01 * k as f32, -1.0, 0.02).normalize());
                let hit = geo.intersect(&ray, 0.0, f32::INFINITY).map(|h| h.instance);
                let brute = BruteForce(&instances).intersect(&ray, 0.0, f32::INFINITY);
                assert_eq!(hit, brute.map(|h| h.instance));
            }
            let bits = |h: &SurfaceHit| {
                let v = |v: Vec3| v.to_array().map(f32::to_bits);
                (h.instance, h.prim, h.t.to_bits(), v(h.p), v(h.ng), v(h.ns))
            };
            let v3 = |s: &mut u64| v(lcg(s), lcg(s), lcg(s)) * 2.0 - 1.0;
            for round in 0..300 {
                let rays: [Option<Ray>; 16] = std::array::from_fn(|i| {
                    // Some rays straight down onto the patches, the rest anywhere.
                    let d = if round % 4 == 0 {
                        v(0.0, -1.0, 0.0)
                    } else {
                        v3(&mut s).normalize()
                    };
                    (i != 5).then(|| Ray::new(v3(&mut s) * 0.9, d))
                });
                check_wave::<16, _>(&geo, &rays, bits);
                check_wave::<8, _>(&geo, &std::array::from_fn(|i| rays[i]), bits);
                check_wave::<4, _>(&geo, &std::array::from_fn(|i| rays[i]), bits);
            }
        }
    }
}
