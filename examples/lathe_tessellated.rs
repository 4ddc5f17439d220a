//! Writes a copy of a JSON scene with every lathe replaced by its tessellation: an inline smooth
//! mesh with the lathe's normals and uvs (the same shared tessellation `tests/lathe_image.rs`
//! uses), for speed comparisons of the exact lathe against a mesh of the same curve.
//!
//! Run: `cargo run --release --example lathe_tessellated -- IN.json OUT.json SEGMENTS RINGS`
//! (2 × SEGMENTS × RINGS triangles per lathe; e.g. 400 × 300 = 240,000). Write OUT beside IN
//! so that relative paths (textures) still resolve.

use lumo_schema::{Mesh, MeshSource, Object, Scene};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output, segments, rings] = args.as_slice() else {
        return Err("usage: lathe_tessellated IN.json OUT.json SEGMENTS RINGS".into());
    };
    let (segments, rings): (u32, u32) = (segments.parse()?, rings.parse()?);
    let mut scene: Scene = serde_json::from_str(&std::fs::read_to_string(input)?)?;
    let mut triangles = 0;
    for obj in &mut scene.objects {
        let Object::Lathe(l) = obj else { continue };
        let t = lumo_schema::geometry::tessellate::lathe(&l.profile, segments, rings);
        triangles += t.indices.len();
        *obj = Object::Mesh(Mesh {
            name: Some(format!(
                "{} (tessellated {segments} × {rings})",
                l.name.as_deref().unwrap_or("lathe")
            )),
            material: l.material.clone(),
            transform: l.transform.clone(),
            source: MeshSource::Inline(t.to_inline()),
            smooth: true,
        });
    }
    std::fs::write(output, serde_json::to_string(&scene)?)?;
    eprintln!("{output}: {triangles} triangles");
    Ok(())
}
