//! What makes a store resumable: the checks of what is already at the store's path and in each
//! array's folder before anything is written, and the per-shard manifests (byte length, crc32c,
//! the tape's and the array metadata's fingerprints) by which a re-run or `texgraph verify`
//! knows a complete shard.

use crate::bake::error::BakeError;
use crate::bake::settings::BakeFileOptions;
use crate::output;
use std::path::Path;

/// Suffix of a shard's manifest key.
pub const MANIFEST_SUFFIX: &str = ".texgraph.json";

/// What is at the store path must be absent, an empty folder, or a Zarr v3 group.
pub(super) fn check_store(store: &Path) -> Result<(), BakeError> {
    output::check_out_folder(store)?;
    if !store.exists() {
        return Ok(());
    }
    let root = store.join("zarr.json");
    match std::fs::read(&root) {
        Ok(bytes) => {
            let doc: serde_json::Value = serde_json::from_slice(&bytes).map_err(|e| {
                BakeError::Refused(format!(
                    "{}: not a Zarr v3 metadata document: {e}",
                    root.display()
                ))
            })?;
            if doc["zarr_format"] != 3 || doc["node_type"] != "group" {
                return Err(BakeError::Refused(format!(
                    "{}: is not a Zarr v3 group (zarr_format {}, node_type {}); refusing to write into it",
                    root.display(),
                    doc["zarr_format"],
                    doc["node_type"]
                )));
            }
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // Another part may have written the document between the two looks.
            if only_metadata_temporaries(store)? || root.exists() {
                Ok(())
            } else {
                Err(BakeError::Refused(format!(
                    "{}: exists and is not a Zarr store (no zarr.json); refusing to write into it: give --out a new path",
                    store.display()
                )))
            }
        }
        Err(e) => Err(BakeError::Io {
            path: root.display().to_string(),
            source: e,
        }),
    }
}

/// Whether `dir` is empty or holds only the temporary of a `zarr.json` another part is writing
/// right now (parts start together; a node's document is written before anything inside it).
fn only_metadata_temporaries(dir: &Path) -> Result<bool, BakeError> {
    Ok(std::fs::read_dir(dir)
        .map_err(|e| BakeError::Io {
            path: dir.display().to_string(),
            source: e,
        })?
        .flatten()
        .all(|entry| {
            entry
                .file_name()
                .to_str()
                .is_some_and(|n| n.starts_with(".zarr.json.") && n.ends_with(".partial"))
        }))
}

/// What to do with an array's folder before writing its metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Existing {
    /// Absent, or baked with the same metadata: write (the same bytes) and resume.
    Resume,
    /// Baked with other settings, and `--force` on a whole bake: remove it first.
    Replace,
}

/// Checks one array's existing metadata: it must be identical to this bake's, else the store
/// was baked with other settings; `--force` on a whole (not split) bake replaces the array, a
/// split bake never does (other parts may be writing it). Writes nothing.
pub(super) fn check_metadata(
    store_dir: &Path,
    name: &str,
    json: &[u8],
    options: &BakeFileOptions,
) -> Result<Existing, BakeError> {
    let dir = store_dir.join(name);
    let doc = dir.join("zarr.json");
    match std::fs::read(&doc) {
        Ok(existing) if existing == json => Ok(Existing::Resume),
        Ok(existing) => {
            let what = mismatch(&existing, json);
            if !(options.force && options.zarr.part.is_whole()) {
                let hint = if options.zarr.part.is_whole() {
                    "pass --force to rebake it with these settings, or bake into a new store"
                } else {
                    "every part of a split bake must use the same graph and settings; delete the store (or bake into a new one) to change them"
                };
                return Err(BakeError::Refused(format!(
                    "{}: was baked with other settings (stored: {what}); {hint}",
                    dir.display()
                )));
            }
            Ok(Existing::Replace)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if dir.exists() && !only_metadata_temporaries(&dir)? {
                // Another part may have written the document between the two looks.
                if doc.exists() {
                    return check_metadata(store_dir, name, json, options);
                }
                return Err(BakeError::Refused(format!(
                    "{}: exists and is not a Zarr array (no zarr.json); refusing to write into it",
                    dir.display()
                )));
            }
            Ok(Existing::Resume)
        }
        Err(e) => Err(BakeError::Io {
            path: doc.display().to_string(),
            source: e,
        }),
    }
}

/// Names the first fields where two metadata documents differ.
fn mismatch(existing: &[u8], wanted: &[u8]) -> String {
    let (Ok(a), Ok(b)) = (
        serde_json::from_slice::<serde_json::Value>(existing),
        serde_json::from_slice::<serde_json::Value>(wanted),
    ) else {
        return "its zarr.json is not valid JSON".into();
    };
    let mut diffs = Vec::new();
    let sharding = |v: &serde_json::Value| v["codecs"][0]["configuration"].clone();
    let (sa, sb) = (sharding(&a), sharding(&b));
    if sa["chunk_shape"] != sb["chunk_shape"] {
        diffs.push(format!(
            "chunks {} but this bake has {}",
            sa["chunk_shape"], sb["chunk_shape"]
        ));
    }
    if sa["codecs"] != sb["codecs"] {
        diffs.push(format!(
            "chunk codecs {} but this bake has {}",
            sa["codecs"], sb["codecs"]
        ));
    }
    for key in ["shape", "data_type", "chunk_grid", "fill_value"] {
        if a[key] != b[key] {
            diffs.push(format!("{key} {} but this bake has {}", a[key], b[key]));
        }
    }
    let (ta, tb) = (&a["attributes"]["texgraph"], &b["attributes"]["texgraph"]);
    for key in ["tape", "region", "size", "precision", "transfer"] {
        if ta[key] != tb[key] {
            diffs.push(format!("{key} {} but this bake has {}", ta[key], tb[key]));
        }
    }
    if diffs.is_empty() && a["codecs"] != b["codecs"] {
        diffs.push("the sharding codec's index differs".into());
    }
    if diffs.is_empty() {
        diffs.push("attributes differ".into());
    }
    diffs.join("; ")
}

/// A shard's manifest, as written beside it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Manifest {
    pub key: String,
    pub bytes: u64,
    /// crc32c of the shard's bytes, 8 hex digits.
    pub crc32c: String,
    /// crc32c of the array's zarr.json the shard belongs to.
    pub array_metadata_crc32c: String,
    /// The tape's fingerprint (attributes.texgraph.tape).
    pub tape: String,
}

/// Why a shard is not complete.
#[derive(Clone, Debug, PartialEq)]
pub enum ShardState {
    Complete,
    Missing,
    NoManifest,
    Corrupt(String),
    Stale(String),
}

/// Checks a shard against its manifest: present, the manifest readable and for this array and
/// tape, length and checksum as recorded.
pub fn shard_state(store_dir: &Path, key: &str, metadata_crc: u32, tape: &str) -> ShardState {
    let path = store_dir.join(key);
    let manifest_path = store_dir.join(format!("{key}{MANIFEST_SUFFIX}"));
    let Ok(bytes) = std::fs::read(&path) else {
        return ShardState::Missing;
    };
    let Ok(text) = std::fs::read(&manifest_path) else {
        return ShardState::NoManifest;
    };
    let manifest: Manifest = match serde_json::from_slice(&text) {
        Ok(m) => m,
        Err(e) => return ShardState::Corrupt(format!("its manifest is unreadable: {e}")),
    };
    if manifest.array_metadata_crc32c != format!("{metadata_crc:08x}") || manifest.tape != tape {
        return ShardState::Stale(format!(
            "baked for another array or tape (manifest: metadata {}, tape {}; array: metadata {metadata_crc:08x}, tape {tape})",
            manifest.array_metadata_crc32c, manifest.tape
        ));
    }
    let crc = format!("{:08x}", crc32c::crc32c(&bytes));
    if manifest.bytes != bytes.len() as u64 || manifest.crc32c != crc {
        return ShardState::Corrupt(format!(
            "{} bytes with crc32c {crc}; its manifest records {} bytes with crc32c {}",
            bytes.len(),
            manifest.bytes,
            manifest.crc32c
        ));
    }
    ShardState::Complete
}

/// Removes hidden temporaries a killed bake left for `key` (`.NAME.XXXXXX.partial`, of the
/// shard or of its manifest) in the key's folder. Only the part that owns a shard writes it, so
/// these are that part's own leftovers.
pub(super) fn remove_stale_temporaries(store_dir: &Path, key: &str) {
    let path = store_dir.join(key);
    let (Some(dir), Some(name)) = (path.parent(), path.file_name().and_then(|n| n.to_str())) else {
        return;
    };
    let prefixes = [format!(".{name}."), format!(".{name}{MANIFEST_SUFFIX}.")];
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(file) = file.to_str() else { continue };
        let ours = prefixes.iter().any(|p| {
            file.strip_prefix(p.as_str())
                .and_then(|rest| rest.strip_suffix(".partial"))
                .is_some_and(|random| !random.is_empty() && !random.contains('.'))
        });
        if ours {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}
