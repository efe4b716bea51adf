//! `texgraph verify`: every shard of every texgraph array in a store checked against its
//! manifest.

use super::resume::{shard_state, ShardState};
use crate::bake::error::BakeError;
use std::path::Path;

/// What `texgraph verify` found in one array.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayCheck {
    /// The array's path in the store (`colour`).
    pub name: String,
    pub shards: u64,
    /// Every shard that is not complete, with why.
    pub problems: Vec<(String, ShardState)>,
}

/// Checks every shard of every texgraph array in the store at `store_dir`: present, with a
/// manifest for this array's metadata and tape, length and crc32c as recorded.
pub fn verify_store(store_dir: &Path) -> Result<Vec<ArrayCheck>, BakeError> {
    let root = store_dir.join("zarr.json");
    let doc = read_json(&root)?;
    if doc["zarr_format"] != 3 || doc["node_type"] != "group" {
        return Err(BakeError::Refused(format!(
            "{}: is not a Zarr v3 group",
            root.display()
        )));
    }
    let mut arrays = Vec::new();
    find_arrays(store_dir, "", &mut arrays)?;
    if arrays.is_empty() {
        return Err(BakeError::Refused(format!(
            "{}: holds no array baked by texgraph",
            store_dir.display()
        )));
    }
    arrays
        .into_iter()
        .map(|name| check_array(store_dir, &name))
        .collect()
}

fn read_json(path: &Path) -> Result<serde_json::Value, BakeError> {
    let bytes = std::fs::read(path).map_err(|e| BakeError::Io {
        path: path.display().to_string(),
        source: e,
    })?;
    serde_json::from_slice(&bytes)
        .map_err(|e| BakeError::Refused(format!("{}: not a JSON document: {e}", path.display())))
}

/// The texgraph arrays under `dir` (a group), depth first, in name order.
fn find_arrays(store_dir: &Path, prefix: &str, out: &mut Vec<String>) -> Result<(), BakeError> {
    let dir = store_dir.join(prefix);
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .map_err(|e| BakeError::Io {
            path: dir.display().to_string(),
            source: e,
        })?
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
        .filter_map(|e| e.file_name().to_str().map(str::to_string))
        .filter(|n| !n.starts_with('.'))
        .collect();
    entries.sort();
    for name in entries {
        let path = if prefix.is_empty() {
            name
        } else {
            format!("{prefix}/{name}")
        };
        let doc_path = store_dir.join(&path).join("zarr.json");
        if !doc_path.exists() {
            continue;
        }
        let doc = read_json(&doc_path)?;
        match doc["node_type"].as_str() {
            Some("array") if doc["attributes"]["texgraph"]["tape"].is_string() => out.push(path),
            Some("group") => find_arrays(store_dir, &path, out)?,
            _ => {}
        }
    }
    Ok(())
}

fn check_array(store_dir: &Path, name: &str) -> Result<ArrayCheck, BakeError> {
    let doc_path = store_dir.join(name).join("zarr.json");
    let bytes = std::fs::read(&doc_path).map_err(|e| BakeError::Io {
        path: doc_path.display().to_string(),
        source: e,
    })?;
    let doc: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| BakeError::Refused(format!("{}: {e}", doc_path.display())))?;
    let numbers = |v: &serde_json::Value| -> Option<Vec<u64>> {
        v.as_array()?.iter().map(|n| n.as_u64()).collect()
    };
    let shape = numbers(&doc["shape"]);
    let shard = numbers(&doc["chunk_grid"]["configuration"]["chunk_shape"]);
    let (Some(shape), Some(shard)) = (shape, shard) else {
        return Err(BakeError::Refused(format!(
            "{}: no regular chunk grid",
            doc_path.display()
        )));
    };
    if shape.len() != shard.len() || shard.contains(&0) {
        return Err(BakeError::Refused(format!(
            "{}: shape and chunk shape disagree",
            doc_path.display()
        )));
    }
    let tape = doc["attributes"]["texgraph"]["tape"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    let crc = crc32c::crc32c(&bytes);
    let counts: Vec<u64> = shape
        .iter()
        .zip(&shard)
        .map(|(n, s)| n.div_ceil(*s))
        .collect();
    let total: u64 = counts.iter().product();
    let mut problems = Vec::new();
    for s in 0..total {
        let mut rest = s;
        let mut index = vec![0; counts.len()];
        for a in (0..counts.len()).rev() {
            index[a] = rest % counts[a];
            rest /= counts[a];
        }
        let key = format!(
            "{name}/c/{}",
            index
                .iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join("/")
        );
        let state = shard_state(store_dir, &key, crc, &tape);
        if state != ShardState::Complete {
            problems.push((key, state));
        }
    }
    Ok(ArrayCheck {
        name: name.to_string(),
        shards: total,
        problems,
    })
}
