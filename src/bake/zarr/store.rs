//! The zarr store on disk: where a graph's store goes ([`store_path`]) and [`AtomicStore`], the
//! `zarrs` storage adapter whose every write is a temporary renamed into place.

use crate::bake::error::BakeError;
use crate::bake::settings::BakeFileOptions;
use crate::output;
use std::path::{Path, PathBuf};
use zarrs::storage::{
    Bytes, OffsetBytesIterator, StorageError, StoreKey, StorePrefix, WritableStorageTraits,
};

/// The store a graph's bake writes: `--out` itself when it ends in `.zarr`, else `DIR/STEM.zarr`.
pub fn store_path(options: &BakeFileOptions) -> Result<PathBuf, BakeError> {
    let out = &options.out_dir;
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
    {
        Ok(out.clone())
    } else {
        Ok(output::join_inside(out, &format!("{}.zarr", options.stem))?)
    }
}

/// A filesystem store whose every `set` is atomic: the value goes to a hidden temporary in the
/// key's folder, is synced and renamed over the key ([`output::write_atomic`]). Only what a bake
/// needs: whole values, erase.
pub struct AtomicStore {
    pub(super) root: PathBuf,
}

impl AtomicStore {
    pub fn new(root: impl Into<PathBuf>) -> AtomicStore {
        AtomicStore { root: root.into() }
    }

    fn path(&self, key: &StoreKey) -> PathBuf {
        self.root.join(key.as_str())
    }

    pub(super) fn write(&self, key: &str, value: &[u8]) -> Result<(), StorageError> {
        let path = self.root.join(key);
        std::fs::create_dir_all(output::parent_dir(&path))?;
        output::write_atomic(&path, |w| w.write_all(value))
            .map_err(|e| StorageError::Other(e.to_string()))
    }
}

impl WritableStorageTraits for AtomicStore {
    fn set(&self, key: &StoreKey, value: Bytes) -> Result<(), StorageError> {
        self.write(key.as_str(), &value)
    }

    fn set_partial_many(
        &self,
        key: &StoreKey,
        _offset_values: OffsetBytesIterator,
    ) -> Result<(), StorageError> {
        Err(StorageError::Other(format!(
            "{}: texgraph writes whole values only",
            key.as_str()
        )))
    }

    fn erase(&self, key: &StoreKey) -> Result<(), StorageError> {
        match std::fs::remove_file(self.path(key)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e.into()),
            _ => Ok(()),
        }
    }

    fn erase_prefix(&self, prefix: &StorePrefix) -> Result<(), StorageError> {
        match std::fs::remove_dir_all(self.root.join(prefix.as_str())) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e.into()),
            _ => Ok(()),
        }
    }

    fn supports_set_partial(&self) -> bool {
        false
    }
}

pub(super) fn storage(path: &str) -> impl Fn(StorageError) -> BakeError + '_ {
    move |e| BakeError::Encode {
        path: path.to_string(),
        message: e.to_string(),
    }
}

/// Writes a node's `zarr.json` (the bytes zarrs serialises) atomically.
pub(super) fn write_node(store_dir: &Path, path: &str, json: &[u8]) -> Result<(), BakeError> {
    let key = if path.is_empty() {
        "zarr.json".to_string()
    } else {
        format!("{path}/zarr.json")
    };
    AtomicStore::new(store_dir)
        .write(&key, json)
        .map_err(storage(&store_dir.join(&key).display().to_string()))
}
