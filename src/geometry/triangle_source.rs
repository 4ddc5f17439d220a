//! [`TriangleSource`]: where a [`TriangleBvh`](super::TriangleBvh) with indexed leaves reads its
//! triangles' corners while it is traversed, instead of from packets of its own.
//!
//! A source is a list of parts, each a mesh's positions and index triples (shared with the mesh,
//! not copied) with an optional object → world map: one part for a mesh's own tree, one per
//! flattened instance for a scene's world-space set. Triangle `i` of the source is triangle
//! `i - first` of the part whose range holds it. The corners are computed by exactly the
//! operations the packets' build uses (the build itself reads them from here), so a tree with
//! indexed leaves meets the same triangles at the same distances as one with packets, bit for
//! bit.

use std::sync::Arc;

use glam::Vec3A;

use crate::geometry::triangle_bvh::{prefetch_line, Prefetch};
use crate::math::{Affine3A, Vec3};

/// One mesh (or one placed instance of it) in a [`TriangleSource`].
#[derive(Debug, Clone)]
pub struct SourcePart {
    /// The source index of this part's first triangle.
    pub first: u32,
    /// The first half of its triangles' ids (the second is the triangle's index in the mesh).
    pub tag: u32,
    /// The mesh's vertex positions.
    pub positions: Arc<Vec<Vec3>>,
    /// The mesh's triangles, indices into `positions`.
    pub triangles: Arc<Vec<[u32; 3]>>,
    /// Object → world, when not the identity.
    pub to_world: Option<Affine3A>,
}

impl SourcePart {
    /// The corners of the triangle of vertices `v`, placed: the one computation of a source's
    /// corners, whether a build reads them or a query gathers them.
    #[inline(always)]
    fn corners(&self, v: [u32; 3]) -> [Vec3A; 3] {
        let p = &self.positions;
        // Spelled out (no `map` closures), so that it inlines into the traversal.
        let c = [p[v[0] as usize], p[v[1] as usize], p[v[2] as usize]];
        let c = match &self.to_world {
            None => c,
            Some(m) => [
                m.transform_point3(c[0]),
                m.transform_point3(c[1]),
                m.transform_point3(c[2]),
            ],
        };
        [Vec3A::from(c[0]), Vec3A::from(c[1]), Vec3A::from(c[2])]
    }
}

/// Triangles numbered from 0 over a list of [`SourcePart`]s (see the module documentation).
#[derive(Debug, Clone, Default)]
pub struct TriangleSource {
    parts: Vec<SourcePart>,
    /// The source's triangle count.
    len: usize,
}

impl TriangleSource {
    /// A source of `parts`, which must number their triangles consecutively from 0 (each
    /// `first` the previous part's `first` plus its triangle count).
    pub fn new(parts: Vec<SourcePart>) -> TriangleSource {
        let mut len = 0usize;
        for p in &parts {
            assert_eq!(p.first as usize, len, "source parts must be consecutive");
            len += p.triangles.len();
        }
        assert!(
            len <= u32::MAX as usize,
            "a triangle source holds at most 2³² − 1 triangles"
        );
        TriangleSource { parts, len }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the source holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The part holding triangle `i`, and `i`'s index in that part's mesh.
    #[inline(always)]
    fn locate(&self, i: u32) -> (&SourcePart, u32) {
        let parts = &self.parts[..];
        let k = if parts.len() == 1 {
            0
        } else {
            parts.partition_point(|p| p.first <= i) - 1
        };
        let part = &parts[k];
        (part, i - part.first)
    }

    /// The three corners of triangle `i` (in world space where its part is placed).
    #[inline(always)]
    pub fn corners(&self, i: u32) -> [Vec3A; 3] {
        let (part, prim) = self.locate(i);
        part.corners(part.triangles[prim as usize])
    }

    /// Triangle `i`'s entry: its corners' indices in its part's positions, then `i`.
    #[inline]
    pub fn entry(&self, i: u32) -> [u32; 4] {
        let (part, prim) = self.locate(i);
        let [a, b, c] = part.triangles[prim as usize];
        [a, b, c, i]
    }

    /// [`corners`](Self::corners) and [`id`](Self::id) of the triangle of `entry`
    /// ([`entry`](Self::entry)), read without its index triple.
    #[inline(always)]
    pub fn entry_triangle(&self, entry: [u32; 4]) -> ([Vec3A; 3], [u32; 2]) {
        let (part, prim) = self.locate(entry[3]);
        (
            part.corners([entry[0], entry[1], entry[2]]),
            [part.tag, prim],
        )
    }

    /// Triangle `i`'s id: its part's tag and its index in the part's mesh.
    #[inline(always)]
    pub fn id(&self, i: u32) -> [u32; 2] {
        let (part, prim) = self.locate(i);
        [part.tag, prim]
    }

    /// Asks the memory system for what [`corners`](Self::corners) of `i` reads: its index
    /// triple, or (once that has arrived) its three positions.
    #[inline]
    pub fn prefetch(&self, i: u32, stage: Prefetch) {
        if i as usize >= self.len {
            return;
        }
        let (part, prim) = self.locate(i);
        match stage {
            Prefetch::Indices => {
                prefetch_line(part.triangles.as_ptr().wrapping_add(prim as usize));
            }
            Prefetch::Corners => {
                for &v in &part.triangles[prim as usize] {
                    prefetch_line(part.positions.as_ptr().wrapping_add(v as usize));
                }
            }
        }
    }
}
