//! A scene that is known to have passed [`validate`](crate::validate()): the type that code
//! which would panic on bad input (index lookups, normalising normals) requires.

use std::ops::Deref;
use std::path::Path;

use crate::diagnostic::Diagnostic;
use crate::scene::Scene;
use crate::validate::validate;

/// A value that passed validation. It can only be made by [`Validated::new`] (which validates)
/// and changed by [`Validated::edit`] (which validates again), so holding one proves the
/// checks ran on exactly this value.
#[derive(Debug, Clone, PartialEq)]
pub struct Validated<T>(T);

impl Validated<Scene> {
    /// Validates `scene`; `base_dir` is the folder its relative paths resolve against (`None`
    /// skips the file-existence checks). Returns every problem found when it is invalid.
    pub fn new(scene: Scene, base_dir: Option<&Path>) -> Result<Self, Vec<Diagnostic>> {
        let diagnostics = validate(&scene, base_dir);
        if diagnostics.is_empty() {
            Ok(Validated(scene))
        } else {
            Err(diagnostics)
        }
    }

    /// Applies `change` to a copy of the scene and validates the result (command-line
    /// overrides go through here). On failure the scene is unchanged.
    pub fn edit(
        &mut self,
        base_dir: Option<&Path>,
        change: impl FnOnce(&mut Scene),
    ) -> Result<(), Vec<Diagnostic>> {
        let mut scene = self.0.clone();
        change(&mut scene);
        *self = Validated::new(scene, base_dir)?;
        Ok(())
    }

    /// The scene, no longer marked as validated (to change it freely).
    pub fn into_inner(self) -> Scene {
        self.0
    }
}

impl<T> Deref for Validated<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T> AsRef<T> for Validated<T> {
    fn as_ref(&self) -> &T {
        &self.0
    }
}
