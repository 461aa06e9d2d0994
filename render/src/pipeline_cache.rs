//! Compiled pipelines kept across runs: wgpu's `PipelineCache` (Vulkan's `VkPipelineCache`) in
//! the platform's cache directory, one file per adapter and driver
//! (`wgpu::util::pipeline_cache_key`), loaded when a renderer opens and written, atomically,
//! after it compiles new pipelines. Drivers keep disk caches of their own (Mesa's, NVIDIA's);
//! this one is what the Vulkan API offers an application on every driver.
//!
//! The file wraps the driver's data in a header of ours — magic, length, FNV-1a hash — so that a
//! truncated or corrupt file is ignored with a warning before the driver sees it. wgpu checks its
//! own header (adapter, driver version) and, with `fallback`, starts an empty cache where the
//! data does not fit. `SKELETRACE_CACHE_DIR` names another directory, `off` none.

use std::path::{Path, PathBuf};

/// The first bytes of a cache file: the format of this wrapper.
const MAGIC: &[u8; 8] = b"SKTPC\x00\x00\x01";

/// Header bytes: magic, payload length, payload hash.
const HEADER: usize = 8 + 8 + 8;

/// 64-bit FNV-1a.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The driver's `data` with the header of this module.
#[must_use]
pub fn wrap(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + data.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a(data).to_le_bytes());
    out.extend_from_slice(data);
    out
}

/// The driver's data in a file's `bytes`, or what is wrong with them.
///
/// # Errors
/// Another format, a length or hash that does not match (a truncated or corrupt file).
pub fn unwrap(bytes: &[u8]) -> Result<&[u8], String> {
    let field = |at: usize| -> Option<u64> {
        Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?))
    };
    if bytes.get(..8) != Some(MAGIC.as_slice()) {
        return Err("not a skeletrace pipeline cache".to_owned());
    }
    let (Some(length), Some(hash)) = (field(8), field(16)) else {
        return Err("truncated header".to_owned());
    };
    let data = &bytes[HEADER..];
    if data.len() as u64 != length {
        return Err(format!(
            "{} bytes of data where the header says {length}",
            data.len()
        ));
    }
    if fnv1a(data) != hash {
        return Err("its data does not match its hash".to_owned());
    }
    Ok(data)
}

/// The directory pipeline caches go to: `SKELETRACE_CACHE_DIR` (`off`: none), else the
/// platform's cache directory (`$XDG_CACHE_HOME` or `~/.cache` on Linux, `~/Library/Caches` on
/// macOS, `%LOCALAPPDATA%` on Windows) with `skeletrace` below it.
#[must_use]
pub fn default_dir() -> Option<PathBuf> {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if let Some(dir) = var("SKELETRACE_CACHE_DIR") {
        return (dir != "off").then(|| PathBuf::from(dir));
    }
    let base = if cfg!(target_os = "windows") {
        var("LOCALAPPDATA").map(PathBuf::from)
    } else if cfg!(target_os = "macos") {
        var("HOME").map(|h| PathBuf::from(h).join("Library/Caches"))
    } else {
        var("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache")))
    };
    base.map(|b| b.join("skeletrace"))
}

/// A device's pipeline cache and the file it is kept in.
pub struct PersistentCache {
    cache: wgpu::PipelineCache,
    path: PathBuf,
    /// Bytes of driver data the cache started from (0: it started empty).
    loaded: u64,
    /// Why the file was not used, if it was not (corrupt, unreadable).
    warning: Option<String>,
}

impl PersistentCache {
    /// The cache of `device` kept in `dir`, started from its file where there is a valid one;
    /// `None` where the device has no pipeline cache (`Features::PIPELINE_CACHE`, Vulkan only).
    #[must_use]
    pub fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo, dir: &Path) -> Option<Self> {
        if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
            return None;
        }
        let path = dir.join(wgpu::util::pipeline_cache_key(info)?);
        let (data, warning) = match std::fs::read(&path) {
            Ok(bytes) => match unwrap(&bytes) {
                Ok(data) => (Some(data.to_vec()), None),
                Err(why) => (
                    None,
                    Some(format!(
                        "pipeline cache {} ignored: {why}; starting empty",
                        path.display()
                    )),
                ),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => (None, None),
            Err(e) => (
                None,
                Some(format!(
                    "pipeline cache {} unreadable: {e}; starting empty",
                    path.display()
                )),
            ),
        };
        if let Some(w) = &warning {
            eprintln!("skeletrace: {w}");
        }
        let cache = create(device, data.as_deref());
        Some(Self {
            cache,
            path,
            loaded: data.map_or(0, |d| d.len() as u64),
            warning,
        })
    }

    /// The cache, for pipeline descriptors.
    #[must_use]
    pub fn cache(&self) -> &wgpu::PipelineCache {
        &self.cache
    }

    /// The cache's file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes of driver data the cache started from: 0 when it started empty (cold).
    #[must_use]
    pub fn loaded_bytes(&self) -> u64 {
        self.loaded
    }

    /// Why the file was not used, where it was not.
    #[must_use]
    pub fn warning(&self) -> Option<&str> {
        self.warning.as_deref()
    }

    /// Writes the cache's data to its file (atomically: a crash leaves the old file).
    ///
    /// # Errors
    /// The folder cannot be made or the file written.
    pub fn save(&self) -> Result<(), String> {
        let Some(data) = self.cache.get_data() else {
            return Ok(());
        };
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot make {}: {e}", dir.display()))?;
        }
        skeletrace_core::output::write_file(&self.path, &wrap(&data), &[])
            .map_err(|e| e.to_string())
    }
}

/// A pipeline cache on `device` started from `data`.
#[expect(
    unsafe_code,
    reason = "wgpu's create_pipeline_cache is unsafe: the data must come from get_data"
)]
fn create(device: &wgpu::Device, data: Option<&[u8]>) -> wgpu::PipelineCache {
    // SAFETY: `data` is what `PersistentCache::save` wrote from `PipelineCache::get_data`:
    // `unwrap` checked the length and hash this module wrote over it, so a truncated or
    // corrupt file never reaches the driver; wgpu then checks its own header (adapter and
    // driver) and with `fallback` starts an empty cache where the data does not fit.
    unsafe {
        device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
            label: Some("skeletrace pipelines"),
            data,
            fallback: true,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wrapped payload reads back; a flipped byte, a cut file, another format and an empty
    /// file are refused, each with its reason.
    #[test]
    fn a_corrupt_or_truncated_cache_file_is_refused() {
        let data: Vec<u8> = (0..1000_u32).map(|i| (i * 7 % 251) as u8).collect();
        let file = wrap(&data);
        assert_eq!(unwrap(&file), Ok(data.as_slice()));
        let mut flipped = file.clone();
        flipped[HEADER + 500] ^= 0x10;
        assert!(unwrap(&flipped).is_err_and(|e| e.contains("hash")));
        assert!(unwrap(&file[..file.len() - 1]).is_err_and(|e| e.contains("header says")));
        assert!(unwrap(&file[..12]).is_err_and(|e| e.contains("truncated")));
        assert!(unwrap(b"").is_err_and(|e| e.contains("not a skeletrace")));
        let mut other = file;
        other[7] = 2;
        assert!(unwrap(&other).is_err_and(|e| e.contains("not a skeletrace")));
        assert_eq!(unwrap(&wrap(&[])), Ok([].as_slice()));
    }
}
