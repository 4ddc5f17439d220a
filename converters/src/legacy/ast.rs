//! The legacy file as written: blocks, fields and objects with their locations, before any
//! mapping to lumo's model. `MaterialIndex` is already resolved (it is a parse-order state).

use super::lexer::Span;

/// A value with the span of the text it came from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located<T> {
    /// The value.
    pub value: T,
    /// Where it was written.
    pub span: Span,
}

/// Three numbers.
pub type V3 = [f32; 3];

/// A whole legacy file. Repeated top-level blocks overwrite earlier ones (later wins).
#[derive(Debug, Clone, Default)]
pub struct Document {
    /// The camera block, if any.
    pub camera: Option<CameraDef>,
    /// `Background { color … }`: the colour and the block's span.
    pub background: Option<(Option<Located<V3>>, Span)>,
    /// The `Lights` block.
    pub lights: Option<LightsDef>,
    /// The `Materials` block.
    pub materials: Option<MaterialsDef>,
    /// The last top-level `Group` (the scene root).
    pub root: Option<ObjectNode>,
    /// Things the parser noticed that are legal but worth telling (span, message).
    pub warnings: Vec<(Span, String)>,
}

/// Which camera block it was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraKind {
    /// `PerspectiveCamera` (optionally with `focalLength`/`aperture`, 1unx1's dialect).
    Perspective,
    /// `DepthCamera` (zhanglbthu, one-step-beh1nd): thin lens with `focalLength` and `aperture`.
    Depth,
    /// `LensCamera` (Chenyu-Yang-2000): thin lens with `depth` and `aperture`.
    Lens,
}

/// A camera block.
#[derive(Debug, Clone)]
pub struct CameraDef {
    /// The block kind.
    pub kind: CameraKind,
    /// Span of the block's keyword.
    pub span: Span,
    /// Eye position.
    pub center: Located<V3>,
    /// View direction (any length).
    pub direction: Located<V3>,
    /// Up vector (re-orthogonalised).
    pub up: Located<V3>,
    /// Vertical field of view in degrees.
    pub angle: Located<f32>,
    /// Image width in pixels.
    pub width: Located<i64>,
    /// Image height in pixels.
    pub height: Located<i64>,
    /// Thin lens: (focus distance, lens radius).
    pub lens: Option<(Located<f32>, Located<f32>)>,
}

/// A `Lights` block.
#[derive(Debug, Clone)]
pub struct LightsDef {
    /// Span of the `Lights` keyword.
    pub span: Span,
    /// The lights in order.
    pub lights: Vec<LightDef>,
}

/// One light.
#[derive(Debug, Clone)]
pub enum LightDef {
    /// `DirectionalLight { direction color }`: direction is the way the light travels.
    Directional {
        /// Block span.
        span: Span,
        /// Travel direction.
        direction: Located<V3>,
        /// Colour.
        color: Located<V3>,
    },
    /// `PointLight { position color }`, no falloff in the original.
    Point {
        /// Block span.
        span: Span,
        /// Position.
        position: Located<V3>,
        /// Colour.
        color: Located<V3>,
    },
}

/// A `Materials` block.
#[derive(Debug, Clone)]
pub struct MaterialsDef {
    /// Span of the `Materials` keyword.
    pub span: Span,
    /// The materials in order (index = position).
    pub materials: Vec<MaterialDef>,
}

/// One material's loose fields (each optional; a repeated field keeps the last value).
#[derive(Debug, Clone, Default)]
pub struct MaterialDef {
    /// Span of the `Material`/`PhongMaterial` keyword.
    pub span: Span,
    /// `diffuseColor` or `color`.
    pub color: Option<Located<V3>>,
    /// `specularColor`.
    pub specular_color: Option<Located<V3>>,
    /// `shininess` (Phong exponent).
    pub shininess: Option<Located<f32>>,
    /// `texture PATH`.
    pub texture: Option<Located<String>>,
    /// `emission` or `emissionColor`.
    pub emission: Option<Located<V3>>,
    /// `type d s r`: lobe weights.
    pub lobe_weights: Option<Located<V3>>,
    /// `refr` or `refractiveIndex`: index of refraction.
    pub refr: Option<Located<f32>>,
    /// `glossy` flag (one-step-beh1nd).
    pub glossy: Option<Located<f32>>,
    /// `reflective k` (jefflyy): mirror weight.
    pub reflective: Option<Located<f32>>,
    /// `transmissive w ior` (jefflyy): transmission weight and IOR.
    pub transmissive: Option<(Located<f32>, Located<f32>)>,
    /// `reflection 0|1|2` (hzt1): diffuse, mirror, glass.
    pub reflection: Option<Located<i64>>,
}

/// A transform step as written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// `Scale x y z`.
    Scale(V3),
    /// `UniformScale s`.
    UniformScale(f32),
    /// `Translate x y z`.
    Translate(V3),
    /// `XRotate deg`.
    XRotate(f32),
    /// `YRotate deg`.
    YRotate(f32),
    /// `ZRotate deg`.
    ZRotate(f32),
    /// `Rotate { axis deg }`.
    Rotate(V3, f32),
    /// `Matrix4f { 16 numbers }` exactly as listed (column by column).
    Matrix4f([f32; 16]),
}

/// Which kind of curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CurveKind {
    /// `BezierCurve`.
    Bezier,
    /// `BsplineCurve`.
    Bspline,
}

/// A curve block.
#[derive(Debug, Clone)]
pub struct CurveDef {
    /// Bézier or B-spline.
    pub kind: CurveKind,
    /// Span of the curve's keyword.
    pub span: Span,
    /// Control points.
    pub points: Vec<Located<V3>>,
}

/// An object with its resolved material (the global current material when it was parsed).
#[derive(Debug, Clone)]
pub struct ObjectNode {
    /// Span of the object's keyword.
    pub span: Span,
    /// Index into the Materials block, `None` before any `MaterialIndex`.
    pub material: Option<usize>,
    /// What it is.
    pub kind: ObjectKind,
}

/// The object kinds.
#[derive(Debug, Clone)]
pub enum ObjectKind {
    /// A nested group.
    Group(Vec<ObjectNode>),
    /// `Sphere { center radius }`.
    Sphere {
        /// Centre.
        center: Located<V3>,
        /// Radius.
        radius: Located<f32>,
    },
    /// `Plane { normal offset }`.
    Plane {
        /// Normal.
        normal: Located<V3>,
        /// Offset along the normal.
        offset: Located<f32>,
    },
    /// `Triangle { vertex0 vertex1 vertex2 }`.
    Triangle([Located<V3>; 3]),
    /// `TriangleMesh { obj_file PATH }`.
    Mesh(Located<String>),
    /// `Transform { ops child }`.
    Transform(Vec<Located<Op>>, Box<ObjectNode>),
    /// A bare curve (not a surface).
    Curve(CurveDef),
    /// `RevSurface { profile curve }`.
    RevSurface(CurveDef),
}
