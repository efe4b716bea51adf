//! Where texgraph writes, and how: every file a command writes (bake outputs and sidecars, PNG
//! slices, renders, report plots) goes through this module.
//!
//! - [`valid_output_name`] accepts only names from the documented character set (the checker
//!   uses it), and [`join_inside`] joins a name under the folder the user named and asserts the
//!   result is a direct child of that folder (defence in depth).
//! - [`check_destination`] refuses a destination that exists and is not what texgraph writes:
//!   a device, a FIFO, a socket, a symbolic link, or a folder where a file goes (and the reverse).
//!   A write renames a temporary over its destination, which would replace a device node.
//! - [`temp_file`], [`temp_dir`] and [`write_atomic`] write into a hidden `.NAME.*.partial` temporary next
//!   to the destination and rename it into place only when complete.
//!
//! The destination is checked before any work and once more right before the rename; a file
//! swapped in between those two moments by another process is outside what this can prevent.

use std::io::Write;
use std::path::{Component, Path, PathBuf};

/// What a destination must be if it already exists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expect {
    /// A regular file (it is replaced).
    File,
    /// A folder (PNG slices: the folder is replaced as a whole).
    Folder,
}

/// Why texgraph will not write somewhere.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The destination exists and is not a regular file (or folder, for slices).
    #[error("{}: is {what}; texgraph replaces only {expected}, never {what}", path.display())]
    NotRegular {
        path: PathBuf,
        what: &'static str,
        expected: &'static str,
    },
    /// A name would place a file outside the output folder.
    #[error("{}: the name {name:?} does not stay inside this folder; refusing to write it", dir.display())]
    Escapes { dir: PathBuf, name: String },
    /// Any other problem with a path given on the command line (extension, missing folder).
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    /// Reading the file system failed.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl OutputError {
    /// The CLI exit code: always 2 (a usage or I/O error).
    pub fn exit_code(&self) -> u8 {
        2
    }
}

/// Longest output name, in bytes (file names are limited to 255 bytes on common file systems,
/// and a bake file is named `STEM.OUTPUT.EXT`).
pub const MAX_OUTPUT_NAME: usize = 64;

/// Names Windows reserves for devices, whatever the extension (`nul.txt` is the device too).
const WINDOWS_RESERVED: [&str; 22] = [
    "CON", "PRN", "AUX", "NUL", "COM1", "COM2", "COM3", "COM4", "COM5", "COM6", "COM7", "COM8",
    "COM9", "LPT1", "LPT2", "LPT3", "LPT4", "LPT5", "LPT6", "LPT7", "LPT8", "LPT9",
];

/// Checks an output name against the documented character set: 1 to [`MAX_OUTPUT_NAME`] ASCII
/// letters, digits, `_`, `-` and `.`; no leading or trailing `.`, no `..`; not a name Windows
/// reserves (`CON`, `NUL`, `COM1`, …, with or without an extension). Returns what is wrong.
pub fn valid_output_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("an output name cannot be empty".into());
    }
    if name.len() > MAX_OUTPUT_NAME {
        return Err(format!(
            "an output name is at most {MAX_OUTPUT_NAME} characters; this one has {}",
            name.chars().count()
        ));
    }
    if let Some(bad) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.')))
    {
        let shown = match bad {
            '/' | '\\' => format!("the path separator `{bad}`"),
            c if c.is_control() || !c.is_ascii() => format!("the character {:?}", c),
            c => format!("the character `{c}`"),
        };
        return Err(format!(
            "an output name becomes part of file names and cannot contain {shown}"
        ));
    }
    if name.starts_with('.') || name.ends_with('.') {
        return Err("an output name cannot start or end with `.`".into());
    }
    if name.contains("..") {
        return Err("an output name cannot contain `..`".into());
    }
    let base = name.split('.').next().unwrap_or(name);
    if WINDOWS_RESERVED
        .iter()
        .any(|r| r.eq_ignore_ascii_case(base))
    {
        return Err(format!(
            "`{base}` is a device name on Windows and cannot start an output name"
        ));
    }
    Ok(())
}

/// The help shown with an invalid output name.
pub const OUTPUT_NAME_HELP: &str = "output names are used in file names: use ASCII letters, digits, `_`, `-` and `.` (not first or last), e.g. \"colour\" or \"height_2\"";

/// Joins `name` (one file or folder name, never a path) under `dir`, asserting that the result
/// is a direct child of `dir`: no separator, no `..`, no root, no drive prefix.
pub fn join_inside(dir: &Path, name: &str) -> Result<PathBuf, OutputError> {
    let escapes = || OutputError::Escapes {
        dir: dir.to_path_buf(),
        name: name.to_string(),
    };
    // Exactly one normal component, spelt as given (no separator, `.`, `..`, root or prefix);
    // `\` and NUL are refused too, since they separate or end paths elsewhere.
    let mut components = Path::new(name).components();
    match (components.next(), components.next()) {
        (Some(Component::Normal(one)), None)
            if one == std::ffi::OsStr::new(name) && !name.contains(['\\', '\0']) =>
        {
            Ok(dir.join(name))
        }
        _ => Err(escapes()),
    }
}

/// What kind of thing is at `path`, in words, if it is not a plain file or folder.
fn describe(file_type: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_symlink() {
        "a symbolic link"
    } else if file_type.is_dir() {
        "a folder"
    } else if file_type.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// Refuses a destination that exists and is not what a write of kind `expect` replaces. A
/// missing destination is fine. Symbolic links are refused (a rename would replace the link,
/// not what it points to, which surprises either way).
pub fn check_destination(path: &Path, expect: Expect) -> Result<(), OutputError> {
    let metadata = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(OutputError::Io {
                path: path.to_path_buf(),
                source,
            })
        }
    };
    let file_type = metadata.file_type();
    let fine = match expect {
        Expect::File => file_type.is_file(),
        Expect::Folder => file_type.is_dir(),
    };
    if fine {
        return Ok(());
    }
    Err(OutputError::NotRegular {
        path: path.to_path_buf(),
        what: describe(file_type),
        expected: match expect {
            Expect::File => "regular files",
            Expect::Folder => "folders here (PNG slices)",
        },
    })
}

/// Checks an output folder given on the command line: if it exists it must be a folder (a link
/// to a folder is fine: the user named it).
pub fn check_out_folder(dir: &Path) -> Result<(), OutputError> {
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(m) => Err(OutputError::Invalid {
            path: dir.to_path_buf(),
            message: format!(
                "the output folder is {}, not a folder",
                describe(m.file_type())
            ),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(OutputError::Io {
            path: dir.to_path_buf(),
            source,
        }),
    }
}

/// Checks a single-file destination given on the command line before any work:
/// [`check_destination`] (what is there now comes first), the extension `ext`
/// (case-insensitive), and an existing folder to write into.
pub fn check_file_argument(path: &Path, ext: &str) -> Result<(), OutputError> {
    let invalid = |message: String| OutputError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    check_destination(path, Expect::File)?;
    let has_ext = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext));
    if !has_ext {
        return Err(invalid(format!(
            "texgraph writes a {} file here; give a name ending in .{ext}",
            ext.to_ascii_uppercase()
        )));
    }
    if path.file_name().is_none() {
        return Err(invalid("not a file name".into()));
    }
    let dir = parent_dir(path);
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(invalid(format!("{} is not a folder", dir.display()))),
        Err(source) => {
            return Err(OutputError::Io {
                path: dir.to_path_buf(),
                source,
            })
        }
    }
    Ok(())
}

/// The folder a path's file goes into (`.` for a bare name).
pub fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Makes the hidden temporary `.NAME.XXXXXX.partial` (a file, or a folder when `folder`) in
/// `dir` that will become `final_path`. It gets the usual 0644 (0755 for folders), less the
/// umask, instead of tempfile's private 0600: it becomes the user's file.
fn make_temp<T>(
    final_path: &Path,
    folder: bool,
    make: impl FnOnce(&tempfile::Builder<'_, '_>) -> std::io::Result<T>,
) -> std::io::Result<T> {
    let name = final_path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("texgraph");
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".partial");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(if folder {
            0o755
        } else {
            0o644
        }));
    }
    #[cfg(not(unix))]
    let _ = folder;
    make(&builder)
}

/// The temporary file that becomes `final_path`, in `dir` (its folder).
pub fn temp_file(dir: &Path, final_path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    make_temp(final_path, false, |b| b.tempfile_in(dir))
}

/// The temporary folder that becomes `final_path`, in `dir` (its folder).
pub fn temp_dir(dir: &Path, final_path: &Path) -> std::io::Result<tempfile::TempDir> {
    make_temp(final_path, true, |b| b.tempdir_in(dir))
}

/// Writes the file `path` atomically: checks the destination, writes a temporary next to it
/// with `write`, syncs it, checks the destination again and renames the temporary over it. On
/// any error the temporary is removed and `path` is untouched.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    check_destination(path, Expect::File)?;
    let io = |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    };
    let temp = temp_file(parent_dir(path), path).map_err(io)?;
    {
        let mut writer = std::io::BufWriter::new(temp.as_file());
        write(&mut writer).map_err(io)?;
        writer.flush().map_err(io)?;
    }
    temp.as_file().sync_all().map_err(io)?;
    check_destination(path, Expect::File)?;
    temp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

/// An 8-bit RGB image, rows from the top, three bytes a pixel: what renders, previews and
/// plots are before they become PNG. A type of texgraph's own: it only ever stores such images
/// and encodes them (the `png` crate does that, as it does for bakes); the `image` crate would
/// bring its colour-management crates into every build for it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl RgbImage {
    /// `data`: `width × height` pixels of three bytes, row by row; `None` for another length.
    pub fn from_raw(width: u32, height: u32, data: Vec<u8>) -> Option<RgbImage> {
        let len = (width as usize)
            .checked_mul(height as usize)?
            .checked_mul(3)?;
        (data.len() == len).then_some(RgbImage {
            width,
            height,
            data,
        })
    }

    /// (width, height) in pixels.
    pub fn dimensions(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Pixel (x, y) as [r, g, b]; panics outside the image.
    pub fn get_pixel(&self, x: u32, y: u32) -> [u8; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the image"
        );
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// The bytes, row by row.
    pub fn as_raw(&self) -> &[u8] {
        &self.data
    }

    pub fn into_raw(self) -> Vec<u8> {
        self.data
    }

    /// The image as a PNG file's bytes (8-bit RGB, fast compression as the bakes use).
    pub fn encode_png(&self) -> Vec<u8> {
        let mut bytes = Vec::new();
        self.write_png_to(&mut bytes)
            .expect("PNG encoding into memory does not fail");
        bytes
    }

    fn write_png_to(&self, writer: impl Write) -> std::io::Result<()> {
        let mut encoder = png::Encoder::new(writer, self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Fast);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(&self.data)
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    }
}

/// Writes `image` as a PNG file, atomically ([`write_atomic`]).
pub fn write_png(path: &Path, image: &RgbImage) -> Result<(), OutputError> {
    write_atomic(path, |w| image.write_png_to(w))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_names_follow_the_documented_set() {
        for good in [
            "colour", "height_2", "a-b", "v1.5", "X", "con_x", "nullable",
        ] {
            assert_eq!(valid_output_name(good), Ok(()), "{good}");
        }
        for bad in [
            "",
            "a/b",
            "d/../../escape",
            "..",
            ".hidden",
            "trailing.",
            "a..b",
            "a\\b",
            "tab\there",
            "zero\u{200b}width",
            "é",
            "NUL",
            "con.txt",
            "Com1",
            "a b",
            "a:b",
            &"x".repeat(65),
        ] {
            assert!(valid_output_name(bad).is_err(), "{bad:?} accepted");
        }
    }

    #[test]
    fn joins_stay_inside_the_folder() {
        let dir = Path::new("out");
        assert_eq!(join_inside(dir, "a.b.raw").unwrap(), dir.join("a.b.raw"));
        for bad in ["../x", "a/b", "/abs", "..", ".", "", "a/../b", "a\\b"] {
            assert!(join_inside(dir, bad).is_err(), "{bad:?} accepted");
        }
    }

    #[cfg(unix)]
    #[test]
    fn non_regular_destinations_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("f.png");
        assert!(
            check_destination(&file, Expect::File).is_ok(),
            "missing is fine"
        );
        std::fs::write(&file, b"x").unwrap();
        assert!(check_destination(&file, Expect::File).is_ok());
        assert!(check_destination(&file, Expect::Folder).is_err());
        let link = dir.path().join("l.png");
        std::os::unix::fs::symlink(&file, &link).unwrap();
        let e = check_destination(&link, Expect::File).unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert!(check_destination(dir.path(), Expect::File)
            .unwrap_err()
            .to_string()
            .contains("a folder"));
        let e = check_destination(Path::new("/dev/null"), Expect::File).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
    }

    #[test]
    fn atomic_writes_leave_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        std::fs::write(&path, b"old").unwrap();
        let e = write_atomic(&path, |w: &mut dyn Write| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_atomic(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
    }
}
