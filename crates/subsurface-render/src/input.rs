//! Reading input files that are untrusted: only regular files, and never more than a limit.
//!
//! A FIFO, `/dev/zero` or a terminal given as a scene, texture or reference used to block
//! forever or read without end; the glTF loader already refused them. Every input file is now
//! read through [`read_regular`]: the file type is checked before the file is opened (opening
//! a FIFO blocks until a writer appears), and the read stops one byte past the limit.

use std::io::Read as _;
use std::path::Path;

/// Largest scene (TOML) or regions (JSON) file: 64 MiB is a million objects' worth of text.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;
/// Largest image file (texture or reference): the glTF loader's buffer limit.
pub const MAX_IMAGE_BYTES: u64 = crate::mesh::MAX_BUFFER_BYTES;

/// Why `path` cannot be read as an input of at most `max_bytes`, in a few words without the
/// path ("not a regular file", "3000000000 bytes, more than the limit of ..."), or `Ok`.
pub fn check_regular(path: &Path, max_bytes: u64) -> Result<std::fs::Metadata, String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(format!("not a regular file ({})", file_kind(&meta)));
    }
    if meta.len() > max_bytes {
        return Err(format!(
            "{} bytes, more than the limit of {max_bytes}",
            meta.len()
        ));
    }
    Ok(meta)
}

/// The bytes of `path`, a regular file of at most `max_bytes` (checked before it is opened,
/// and again while reading, in case it grew in between). Errors are a few words without the
/// path, as [`check_regular`]'s.
pub fn read_regular(path: &Path, max_bytes: u64) -> Result<Vec<u8>, String> {
    let meta = check_regular(path, max_bytes)?;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > max_bytes {
        return Err(format!("more than the limit of {max_bytes} bytes"));
    }
    Ok(bytes)
}

/// [`read_regular`] as UTF-8 text.
pub fn read_regular_text(path: &Path, max_bytes: u64) -> Result<String, String> {
    String::from_utf8(read_regular(path, max_bytes)?)
        .map_err(|_| "stream did not contain valid UTF-8".to_string())
}

fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_os = "linux")]
    #[test]
    fn devices_fifos_directories_and_big_files_are_refused_without_reading() {
        let e = read_regular(Path::new("/dev/zero"), 10).unwrap_err();
        assert_eq!(e, "not a regular file (a character device)");
        let e = read_regular(Path::new("/"), 10).unwrap_err();
        assert_eq!(e, "not a regular file (a directory)");
        let dir = std::env::temp_dir().join(format!("subsurface-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("f");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success());
        if made {
            // Returns at once: opening the FIFO would block with no writer.
            let e = read_regular(&fifo, 10).unwrap_err();
            assert_eq!(e, "not a regular file (a FIFO)");
        }
        let big = dir.join("big");
        std::fs::write(&big, [0u8; 11]).unwrap();
        let e = read_regular(&big, 10).unwrap_err();
        assert_eq!(e, "11 bytes, more than the limit of 10");
        assert_eq!(read_regular(&big, 11).unwrap().len(), 11);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
