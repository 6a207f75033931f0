//! `scene.json`: the scene a run simulated, written into its output folder before the first
//! step, so that what reads the folder afterwards (`mbdc view`) knows the bodies' inertia,
//! the joints' points and axes, the springs and the contact planes without the model file.
//!
//! It is the [`Scene`] as the run saw it (parameters applied), with each mesh's nodes,
//! elements, node sets and conditions left out: the `.vtu` files of the run hold the mesh
//! geometry, and a mesh of 10⁶ elements would make the file hundreds of megabytes.
//! Written atomically (temporary file, rename), like `summary.json`.

use std::path::Path;

use super::{OutputError, OutputErrorKind};
use crate::contract::scene::Scene;

/// The file's name in an output folder.
pub const SCENE_FILE: &str = "scene.json";

/// Write `DIR/scene.json` (creating `DIR`): `scene` without its meshes' node and element
/// data (see the module doc).
pub fn write_scene(dir: &Path, scene: &Scene) -> Result<(), OutputError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| OutputError::io(OutputErrorKind::CreateDir, dir, e))?;
    let mut light = scene.clone();
    for m in &mut light.meshes {
        m.nodes = Vec::new();
        m.elements = Vec::new();
        m.node_sets = Vec::new();
        m.conditions = Vec::new();
    }
    let path = dir.join(SCENE_FILE);
    let text = serde_json::to_string(&light).map_err(|e| OutputError::Json {
        path: path.clone(),
        message: e.to_string(),
    })?;
    super::replace_file::replace_file(&path, format!("{text}\n").as_bytes())
}

/// Read a `scene.json` written by [`write_scene`].
pub fn read_scene(path: &Path) -> Result<Scene, OutputError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| OutputError::io(OutputErrorKind::Read, path, e))?;
    serde_json::from_str(&text).map_err(|e| OutputError::Json {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}
