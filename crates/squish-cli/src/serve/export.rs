//! Export from the page, written only inside the scene's folder: the edited parameters as a scene
//! file that `squish run` renders to the page's result (the scene's own tables with the page's
//! keys written over them, painted bulge maps as per-vertex text files it references), and the
//! current frame's deformed meshes as OBJ.
//!
//! Every name a request gives is one plain file-name part (letters, digits, `-`, `_`), so that no
//! request can reach outside the folder (`..`, separators, absolute paths and drive prefixes are
//! all refused), and the joined path is checked to sit directly in the folder.

use std::path::{Path, PathBuf};

use serde::Serialize;
use squish::TriMesh;
use squish_io::scene::MeshSource;
use squish_io::write_obj;
use toml::Value;

use super::session::{Computed, Session, relative_to};
use squish_shot::scene_shot::file_numbering;

/// Longest export name.
const MAX_NAME_LEN: usize = 64;

/// What an export wrote, paths relative to the scene's folder.
#[derive(Serialize)]
pub struct Exported {
    pub scene: String,
    pub maps: Vec<String>,
    pub meshes: Vec<String>,
    /// The command that renders the exported scene (from the scene's folder).
    pub command: String,
}

/// `name` checked as one plain file-name part.
pub fn checked_name(name: &str) -> Result<&str, String> {
    let plain = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
    if name.is_empty() || name.len() > MAX_NAME_LEN || !name.chars().all(plain) || name.starts_with('-') {
        return Err(format!(
            "export name \"{}\" must be 1–{MAX_NAME_LEN} letters, digits, '-' or '_' (a file name in the scene's folder)",
            name.chars().take(MAX_NAME_LEN).collect::<String>()
        ));
    }
    Ok(name)
}

/// `folder/file`, refused unless it lies directly in `folder`.
pub fn inside(folder: &Path, file: &str) -> Result<PathBuf, String> {
    let path = folder.join(file);
    if path.parent() != Some(folder) || Path::new(file).components().count() != 1 {
        return Err(format!("\"{file}\" is not a file of the scene's folder {}", folder.display()));
    }
    Ok(path)
}

/// Writes `name.toml`, `name-OBJECT-bulge.txt` (painted maps) and `name-frame-N/OBJECT.obj`.
pub fn export(session: &Session, computed: &Computed, name: &str) -> Result<Exported, String> {
    let name = checked_name(name)?;
    let folder = &session.folder;
    let mut description = session.scene.description().clone();
    let numbering = file_numbering(&session.scene, &computed.shot);
    let mut maps = Vec::new();
    for (i, object) in description.objects.iter_mut().enumerate() {
        for (key, value) in session.edits.objects.get(i).into_iter().flatten() {
            object.params.insert(key.clone(), value.clone());
        }
        if let Some(Some(map)) = session.edits.painted.get(i) {
            let file = format!("{name}-{}-bulge.txt", plain_part(&object.name));
            let path = inside(folder, &file)?;
            let in_file_order = numbering.get(i).and_then(|n| n.vertex_map.as_ref()).map_or_else(
                || map.clone(),
                |vertex_map| vertex_map.iter().map(|&v| map.get(v as usize).copied().unwrap_or(1.0)).collect(),
            );
            let text: String = in_file_order.iter().map(|eta| format!("{eta}\n")).collect();
            std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            object.params.insert("bulge_map".into(), Value::String(file.clone()));
            maps.push(file);
        }
        let file = match &mut object.mesh {
            MeshSource::File { file, .. } | MeshSource::Sequence { pattern: file, .. } => file,
            MeshSource::Gltf(g) => &mut g.file,
        };
        *file = relative_to(file, folder);
    }
    for (i, pair) in description.pairs.iter_mut().enumerate() {
        for (key, value) in session.edits.pairs.get(i).into_iter().flatten() {
            pair.params.insert(key.clone(), value.clone());
        }
    }
    // Articulations: an entry's own table, or `[objects.articulations."name"]` for the automatic.
    for (i, object) in description.objects.iter_mut().enumerate() {
        let names = session.articulations.get(i).map(Vec::as_slice).unwrap_or(&[]);
        for (k, edited) in session.edits.articulations.get(i).into_iter().flatten().enumerate() {
            let Some((name, automatic)) = names.get(k) else { continue };
            let table = if *automatic {
                if edited.is_empty() {
                    continue;
                }
                object.articulations.entry(name.clone()).or_default()
            } else {
                match object.self_contact.get_mut(k) {
                    Some(entry) => &mut entry.params,
                    None => continue,
                }
            };
            for (key, value) in edited {
                table.insert(key.clone(), value.clone());
            }
        }
    }
    description.output.dir = PathBuf::from(format!("{name}-out"));
    // Per-vertex files the scene already named keep their (absolute) paths, except the maps
    // written above, which sit beside the scene file.
    let mut text = toml::to_string(&description).map_err(|e| format!("cannot write the scene as TOML: {e}"))?;
    text.insert_str(0, &format!("# Exported by `squish serve` from {}.\n", session.scene.path().display()));
    let scene_file = format!("{name}.toml");
    let scene_path = inside(folder, &scene_file)?;
    std::fs::write(&scene_path, text).map_err(|e| format!("cannot write {}: {e}", scene_path.display()))?;

    let frame = session.edits.frame;
    let meshes_dir_name = format!("{name}-frame-{frame}");
    let meshes_dir = inside(folder, &meshes_dir_name)?;
    std::fs::create_dir_all(&meshes_dir).map_err(|e| format!("cannot create {}: {e}", meshes_dir.display()))?;
    let mut meshes = Vec::new();
    for (i, object) in computed.shot.objects.iter().enumerate() {
        let file = format!("{}.obj", plain_part(&object.name));
        let positions = &computed.result.positions[i];
        let mesh = match numbering.get(i) {
            Some(n) => n.file_mesh(positions),
            None => TriMesh { positions: positions.clone(), triangles: object.mesh.triangles.clone() },
        };
        write_obj(&meshes_dir.join(&file), &mesh).map_err(|e| e.to_string())?;
        meshes.push(format!("{meshes_dir_name}/{file}"));
    }
    Ok(Exported { command: format!("squish run {scene_file} --frames {frame}"), scene: scene_file, maps, meshes })
}

/// An object's name as part of a file name.
fn plain_part(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn names_that_leave_the_folder_are_refused() {
        for bad in ["..", "../x", "a/b", "/etc/passwd", "a\\b", "C:x", "", ".hidden", "-rf", "x y", "é"] {
            assert!(checked_name(bad).is_err(), "{bad:?} must be refused");
        }
        assert!(checked_name(&"a".repeat(65)).is_err());
        assert_eq!(checked_name("edited_2-b").unwrap(), "edited_2-b");
        let folder = Path::new("/scenes/press");
        assert!(inside(folder, "../escape.toml").is_err());
        assert!(inside(folder, "/etc/passwd").is_err());
        assert!(inside(folder, "sub/x").is_err());
        assert_eq!(inside(folder, "ok.toml").unwrap(), folder.join("ok.toml"));
    }
}
