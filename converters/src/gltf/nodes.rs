//! Where cameras and lights sit as glTF nodes: the values and node transforms the exporter
//! writes, which the importer compares against to recognise lumo's own exports.

use lumo_schema::{Camera, Image, Light};

use super::math;

/// glTF yfov (radians) and aspect ratio the exporter writes for a camera and image.
pub fn camera_values(c: &Camera, image: &Image) -> (f32, f32) {
    (
        f64::from(c.fov_y_deg).to_radians() as f32,
        image.width as f32 / image.height.max(1) as f32,
    )
}

/// The camera node's TRS: translation = position; rotation maps −z to the view direction and
/// +y to the up vector made orthogonal to it.
pub fn camera_node_trs(c: &Camera) -> ([f32; 3], [f32; 4]) {
    let p = math::f64x3(c.position);
    let f = math::normalize(math::sub(math::f64x3(c.look_at), p)).unwrap_or([0.0, 0.0, -1.0]);
    (c.position, look_rotation(f, math::f64x3(c.up)))
}

/// The rotation quaternion (x, y, z, w) mapping −z to the unit direction `f` and +y to `up` made
/// orthogonal to it (glTF's camera and light convention).
fn look_rotation(f: [f64; 3], up: [f64; 3]) -> [f32; 4] {
    let r = math::normalize(math::cross(f, up)).unwrap_or([1.0, 0.0, 0.0]);
    let u = math::cross(r, f);
    let mut m = math::IDENTITY;
    for i in 0..3 {
        m[i][0] = r[i];
        m[i][1] = u[i];
        m[i][2] = -f[i];
    }
    math::quat_from_rotation(&m).map(|x| x as f32)
}

/// The f32 world matrix of the camera node the exporter writes.
pub fn camera_node_matrix(c: &Camera) -> [[f32; 4]; 4] {
    let (t, q) = camera_node_trs(c);
    math::to_f32(&math::trs(t, q, [1.0; 3]))
}

/// A light node's TRS: translation = position (point, spot); rotation maps −z to the direction
/// (spot, directional).
pub fn light_node_trs(l: &Light) -> (Option<[f32; 3]>, Option<[f32; 4]>) {
    let rot = |d: [f32; 3]| {
        let f = math::normalize(math::f64x3(d)).unwrap_or([0.0, 0.0, -1.0]);
        // Any up not parallel to f.
        let up = if f[1].abs() < 0.9 {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        look_rotation(f, up)
    };
    match l {
        Light::Point(p) => (Some(p.position), None),
        Light::Directional(d) => (None, Some(rot(d.direction))),
        Light::Spot(s) => (Some(s.position), Some(rot(s.direction))),
    }
}

/// The f32 world matrix of the light node the exporter writes.
pub fn light_node_matrix(l: &Light) -> [[f32; 4]; 4] {
    let (t, r) = light_node_trs(l);
    math::to_f32(&math::trs(
        t.unwrap_or([0.0; 3]),
        r.unwrap_or([0.0, 0.0, 0.0, 1.0]),
        [1.0; 3],
    ))
}
