//! The checked-in `schema/scene.schema.json` must be exactly what the types generate, so editors
//! never validate against a stale schema. Regenerate with `cargo run -- schema -o schema/scene.schema.json`
//! (or run this test with `LUMO_BLESS=1`).

#[test]
fn checked_in_schema_is_current() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scene.schema.json");
    let generated = lumo_schema::json_schema();
    if std::env::var_os("LUMO_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == generated,
        "schema/scene.schema.json is stale: run `cargo run -- schema -o schema/scene.schema.json`"
    );
}

#[test]
fn checked_in_fragment_schema_is_current() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scene-fragment.schema.json");
    let generated = lumo_schema::json_fragment_schema();
    if std::env::var_os("LUMO_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == generated,
        "schema/scene-fragment.schema.json is stale: run \
         `cargo run -- schema --fragment -o schema/scene-fragment.schema.json`"
    );
    // The scene's schema with every top-level member optional, and the same definitions.
    let fragment: serde_json::Value = serde_json::from_str(&generated).unwrap();
    let scene: serde_json::Value = serde_json::from_str(&lumo_schema::json_schema()).unwrap();
    assert!(fragment.get("required").is_none());
    assert!(scene["required"].as_array().is_some_and(|r| !r.is_empty()));
    assert_eq!(fragment["properties"], scene["properties"]);
    assert_eq!(fragment["$defs"], scene["$defs"]);
    assert!(fragment["properties"]["include"].is_object());
}

#[test]
fn schema_is_draft_2020_12_with_ranges_and_descriptions() {
    let schema: serde_json::Value = serde_json::from_str(&lumo_schema::json_schema()).unwrap();
    assert_eq!(
        schema["$schema"],
        "https://json-schema.org/draft/2020-12/schema"
    );
    let sphere = &schema["$defs"]["Sphere"]["properties"];
    assert_eq!(sphere["radius"]["exclusiveMinimum"], 0);
    assert!(sphere["radius"]["description"]
        .as_str()
        .unwrap()
        .contains("scene units"));
    assert_eq!(schema["$defs"]["Sphere"]["additionalProperties"], false);
}
