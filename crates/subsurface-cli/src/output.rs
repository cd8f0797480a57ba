//! Writing output files so that a failed or interrupted write leaves no partial file.
//!
//! A regular (or not yet existing) file is written to a hidden temporary file beside it and
//! renamed over it, so readers never see half a PNG. Anything else is written in place:
//! renaming over a device or FIFO would replace the node itself (as root, `--out /dev/full`
//! used to turn the device into a PNG), and `-` or `/dev/stdout` cannot be renamed at all.
//! A symbolic link is followed, and its final target is what gets replaced, so the link stays.

use std::fs::{File, OpenOptions};
use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, Once, PoisonError};

use anyhow::{Context, Result, bail};

/// Where the bytes go.
enum Sink {
    /// A temporary file in `target`'s directory, renamed onto `target` on commit. `file` is
    /// opened only by the first write, so no partial file sits on disk during a long render.
    Replace {
        target: PathBuf,
        tmp: PathBuf,
        file: Option<File>,
    },
    /// Written in place: a device, FIFO or `/proc/self/fd` entry. A FIFO is opened only by
    /// the first write, because opening it blocks until a reader appears.
    InPlace {
        file: Option<File>,
    },
    Stdout,
}

/// An output file being written. Nothing becomes visible at the destination until
/// [`commit`](Self::commit) (except for destinations written in place), and a partial
/// temporary file is removed on error (drop) and on Ctrl-C/SIGTERM.
pub struct PendingFile {
    /// The path as the user gave it, for messages.
    dest: PathBuf,
    sink: Sink,
}

impl PendingFile {
    /// Checks now that `dest` can be written, so a bad path fails before any work, without
    /// leaving a file behind. `-` means standard output.
    pub fn create(dest: &Path) -> Result<Self> {
        let name = dest.display();
        if dest.as_os_str() == "-" {
            return Ok(Self {
                dest: dest.to_path_buf(),
                sink: Sink::Stdout,
            });
        }
        let sink = match resolve(dest)? {
            Resolved::Stdout => Sink::Stdout,
            Resolved::InPlace { fifo: true } => Sink::InPlace { file: None },
            Resolved::InPlace { fifo: false } => Sink::InPlace {
                file: Some(open_in_place(dest)?),
            },
            Resolved::Replace(target) => {
                let tmp = tmp_path(&target);
                // Creating and removing the temporary file is the only portable test that the
                // directory accepts new files; the registry lock keeps Ctrl-C from exiting
                // between the two.
                let _guard = registry();
                File::create(&tmp).with_context(|| format!("{name}: cannot write here"))?;
                let _ = std::fs::remove_file(&tmp);
                Sink::Replace {
                    target,
                    tmp,
                    file: None,
                }
            }
        };
        Ok(Self {
            dest: dest.to_path_buf(),
            sink,
        })
    }

    /// Whether the bytes go to standard output (`-`, `/dev/stdout`), where a summary line
    /// printed with `println!` would end up inside the file (see [`print_summary`]).
    pub fn writes_to_stdout(&self) -> bool {
        matches!(self.sink, Sink::Stdout)
    }

    /// Encodes `image` (8-bit RGB or RGBA) as PNG and writes and commits it.
    pub fn write_png<P>(mut self, image: &image::ImageBuffer<P, Vec<u8>>) -> Result<()>
    where
        P: image::Pixel<Subpixel = u8> + image::PixelWithColorType,
    {
        self.write_bytes(&png_bytes(image, &self.dest)?)?;
        self.commit()
    }

    /// Appends `bytes`.
    pub fn write_bytes(&mut self, bytes: &[u8]) -> Result<()> {
        let name = self.dest.display();
        let failed = || format!("{name}: write failed");
        match &mut self.sink {
            Sink::Replace { tmp, file, .. } => {
                if file.is_none() {
                    *file = Some(
                        create_registered(tmp)
                            .with_context(|| format!("{name}: cannot write here"))?,
                    );
                }
                let f = file.as_mut().expect("opened above");
                f.write_all(bytes).with_context(failed)
            }
            Sink::InPlace { file } => {
                if file.is_none() {
                    *file = Some(open_in_place(&self.dest)?);
                }
                let f = file.as_mut().expect("opened above");
                f.write_all(bytes)
                    .and_then(|()| f.flush())
                    .with_context(failed)
            }
            Sink::Stdout => {
                let mut out = std::io::stdout().lock();
                out.write_all(bytes)
                    .and_then(|()| out.flush())
                    .with_context(|| "stdout: write failed")
            }
        }
    }

    /// Makes what was written the destination's content.
    pub fn commit(mut self) -> Result<()> {
        let name = self.dest.display().to_string();
        match &mut self.sink {
            Sink::Replace { target, tmp, file } => {
                let f = match file.take() {
                    Some(f) => f,
                    None => create_registered(tmp)
                        .with_context(|| format!("{name}: cannot write here"))?,
                };
                // Without the sync a crash soon after the rename can leave an empty file.
                f.sync_all()
                    .with_context(|| format!("{name}: write failed"))?;
                drop(f);
                if let Ok(old) = std::fs::metadata(&*target) {
                    let _ = std::fs::set_permissions(&*tmp, old.permissions());
                }
                let mut reg = registry();
                std::fs::rename(&*tmp, &*target)
                    .with_context(|| format!("{name}: cannot write here"))?;
                reg.retain(|p| p != tmp);
                Ok(())
            }
            // Opening a FIFO nobody wrote to still lets its reader see end-of-file.
            Sink::InPlace { file: None } => open_in_place(&self.dest).map(drop),
            Sink::InPlace { .. } | Sink::Stdout => Ok(()),
        }
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        if let Sink::Replace { tmp, file, .. } = &mut self.sink {
            drop(file.take());
            // Unregistered means never created, renamed, or already removed by the handler.
            let mut reg = registry();
            if let Some(i) = reg.iter().position(|p| p == tmp) {
                let _ = std::fs::remove_file(&*tmp);
                reg.swap_remove(i);
            }
        }
    }
}

/// `image` (8-bit RGB or RGBA) encoded as PNG; `dest` names the file in the error.
pub fn png_bytes<P>(image: &image::ImageBuffer<P, Vec<u8>>, dest: &Path) -> Result<Vec<u8>>
where
    P: image::Pixel<Subpixel = u8> + image::PixelWithColorType,
{
    use image::ImageEncoder as _;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(image.as_raw(), image.width(), image.height(), P::COLOR_TYPE)
        .with_context(|| format!("{}: PNG encoding failed", dest.display()))?;
    Ok(bytes)
}

/// Makes a write past the file-size limit (`ulimit -f`) fail with EFBIG, an error the
/// command reports and cleans up after, instead of killing the process by SIGXFSZ (status
/// 153), which left `.out.png.partial-PID-0` behind.
pub fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to SIG_IGN installs no handler code; it is
    // called once, at start-up, before any thread is spawned.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// Whether `dest` names standard output (`-`, `/dev/stdout`, a link to it), as
/// [`PendingFile::create`] would find; checked without writing anything.
pub fn is_stdout(dest: &Path) -> bool {
    dest.as_os_str() == "-" || matches!(resolve(dest), Ok(Resolved::Stdout))
}

/// Prints a command's summary `text` (which ends in its own line feed) on standard output, or
/// on standard error when `stdout_taken`: the command writes a file to standard output
/// ([`PendingFile::writes_to_stdout`]), and the text would end up inside it.
pub fn print_summary(stdout_taken: bool, text: &str) {
    if stdout_taken {
        eprint!("{text}");
    } else {
        print!("{text}");
    }
}

enum Resolved {
    Replace(PathBuf),
    InPlace { fifo: bool },
    Stdout,
}

/// Follows symbolic links to the node that will be written, and decides how.
fn resolve(dest: &Path) -> Result<Resolved> {
    let name = dest.display();
    let mut path = dest.to_path_buf();
    let mut followed = false;
    // Linux's own limit on links followed in one lookup.
    for _ in 0..40 {
        let file = path
            .file_name()
            .with_context(|| format!("{name}: not a file path"))?
            .to_owned();
        let dir = parent_dir(&path);
        // Resolving the directory too turns /dev/fd/1 into /proc/PID/fd/1, checked below.
        let dir = match std::fs::canonicalize(dir) {
            Ok(d) => d,
            Err(e) if e.kind() == ErrorKind::NotFound && followed => bail!(
                "{name}: symbolic link to {}, whose directory does not exist",
                path.display()
            ),
            Err(e) if e.kind() == ErrorKind::NotFound => {
                bail!("{name}: directory {} does not exist", dir.display())
            }
            Err(e) => return Err(e).with_context(|| format!("{name}: cannot write here")),
        };
        path = dir.join(file);
        // /dev/stdout and /dev/fd/N lead here; their link text ("pipe:[123]") is no path, and
        // reopening the file behind stdout would write at another offset than println! does.
        if path.starts_with("/proc") {
            return Ok(if is_own_stdout(&path) {
                Resolved::Stdout
            } else {
                Resolved::InPlace { fifo: false }
            });
        }
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&path)
                    .with_context(|| format!("{name}: cannot read the symbolic link"))?;
                path = parent_dir(&path).join(link);
                followed = true;
            }
            // Replacing it by a rename would succeed in a writable directory; a read-only
            // file is a request not to.
            Ok(m) if m.is_file() && m.permissions().readonly() => {
                bail!("{name}: the file is read-only")
            }
            Ok(m) if m.is_file() => return Ok(Resolved::Replace(path)),
            Ok(m) if m.is_dir() => bail!("{name}: is a directory"),
            Ok(m) => return Ok(Resolved::InPlace { fifo: is_fifo(&m) }),
            Err(e) if e.kind() == ErrorKind::NotFound => return Ok(Resolved::Replace(path)),
            Err(e) => return Err(e).with_context(|| format!("{name}: cannot write here")),
        }
    }
    bail!("{name}: too many levels of symbolic links")
}

fn is_own_stdout(path: &Path) -> bool {
    let pid = std::process::id().to_string();
    ["self", "thread-self", pid.as_str()]
        .iter()
        .any(|p| path == Path::new("/proc").join(p).join("fd/1"))
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// A hidden temporary file beside `target`, unique to this process and this output.
fn tmp_path(target: &Path) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let file_name = target.file_name().unwrap_or_default().to_string_lossy();
    parent_dir(target).join(format!(
        ".{file_name}.partial-{}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ))
}

#[cfg(unix)]
fn is_fifo(m: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt as _;
    m.file_type().is_fifo()
}

#[cfg(not(unix))]
fn is_fifo(_: &std::fs::Metadata) -> bool {
    false
}

/// Opens an existing device, FIFO or descriptor for writing, never creating or truncating it.
fn open_in_place(dest: &Path) -> Result<File> {
    OpenOptions::new()
        .write(true)
        .open(dest)
        .with_context(|| format!("{}: cannot write here", dest.display()))
}

// ------------------------------------------------------------ partial files and signals

/// Temporary files that exist on disk and are not yet renamed into place. Every change to
/// the file system that adds or removes one happens while holding this lock, so the signal
/// handler (which exits holding it) never misses one.
static PARTIAL: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn registry() -> MutexGuard<'static, Vec<PathBuf>> {
    PARTIAL.lock().unwrap_or_else(PoisonError::into_inner)
}

fn create_registered(tmp: &Path) -> std::io::Result<File> {
    install_signal_handler();
    let mut reg = registry();
    let f = File::create(tmp)?;
    reg.push(tmp.to_path_buf());
    Ok(f)
}

/// Removes every registered partial file; returns how many were registered.
fn remove_partial_files(reg: &mut Vec<PathBuf>) -> usize {
    let n = reg.len();
    for p in reg.drain(..) {
        let _ = std::fs::remove_file(p);
    }
    n
}

/// Ctrl-C (and SIGTERM/SIGHUP) would otherwise kill the process before `Drop` runs. Installed
/// only once a partial file may exist, so commands that never write keep the default.
fn install_signal_handler() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let result = ctrlc::set_handler(|| {
            let mut reg = registry();
            remove_partial_files(&mut reg);
            // Exiting with the lock held keeps the main thread from creating another file.
            std::process::exit(130);
        });
        if let Err(e) = result {
            log::debug!("no interrupt handler, partial files may survive Ctrl-C: {e}");
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tempdir(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("subsurface-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn partials(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".partial-"))
            .collect()
    }

    #[test]
    fn nothing_on_disk_until_written_and_replaced_on_commit() {
        let dir = tempdir("regular");
        let dest = dir.join("a.txt");
        let mut p = PendingFile::create(&dest).unwrap();
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        p.write_bytes(b"one ").unwrap();
        p.write_bytes(b"two").unwrap();
        assert_eq!(partials(&dir).len(), 1);
        assert!(!dest.exists());
        p.commit().unwrap();
        assert_eq!(std::fs::read(&dest).unwrap(), b"one two");
        assert!(partials(&dir).is_empty());

        let mut p = PendingFile::create(&dest).unwrap();
        p.write_bytes(b"half").unwrap();
        drop(p);
        assert_eq!(std::fs::read(&dest).unwrap(), b"one two");
        assert!(partials(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn stdout_is_recognised_without_writing() {
        let dir = tempdir("stdout");
        assert!(is_stdout(Path::new("-")));
        assert!(
            PendingFile::create(Path::new("-"))
                .unwrap()
                .writes_to_stdout()
        );
        if cfg!(target_os = "linux") {
            assert!(is_stdout(Path::new("/dev/stdout")));
            assert!(!is_stdout(Path::new("/dev/stderr")));
        }
        let file = dir.join("a.png");
        assert!(!is_stdout(&file));
        assert!(!PendingFile::create(&file).unwrap().writes_to_stdout());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn missing_directory_and_directory_fail_at_create() {
        let dir = tempdir("missing");
        let dest = dir.join("nope").join("a.png");
        let e = format!("{:#}", PendingFile::create(&dest).err().unwrap());
        assert!(e.contains("nope") && e.contains("does not exist"), "{e}");
        let e = format!("{:#}", PendingFile::create(&dir).err().unwrap());
        assert!(e.ends_with("is a directory"), "{e}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn symbolic_links_are_followed_not_replaced() {
        use std::os::unix::fs::symlink;
        let dir = tempdir("symlink");
        std::fs::create_dir(dir.join("real")).unwrap();
        // Relative, chained, and dangling into an existing directory.
        symlink("real/t.txt", dir.join("l1")).unwrap();
        symlink("l1", dir.join("l2")).unwrap();
        let mut p = PendingFile::create(&dir.join("l2")).unwrap();
        p.write_bytes(b"x").unwrap();
        p.commit().unwrap();
        for l in ["l1", "l2"] {
            let m = std::fs::symlink_metadata(dir.join(l)).unwrap();
            assert!(m.file_type().is_symlink(), "{l}");
        }
        assert_eq!(std::fs::read(dir.join("real/t.txt")).unwrap(), b"x");
        assert!(partials(&dir.join("real")).is_empty());

        symlink(dir.join("gone/t.txt"), dir.join("dangling")).unwrap();
        let e = format!(
            "{:#}",
            PendingFile::create(&dir.join("dangling")).err().unwrap()
        );
        assert!(
            e.contains("dangling: symbolic link to") && e.contains("gone"),
            "{e}"
        );

        symlink("loop", dir.join("loop")).unwrap();
        let e = format!(
            "{:#}",
            PendingFile::create(&dir.join("loop")).err().unwrap()
        );
        assert!(e.contains("too many levels"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_read_only_file_is_not_replaced() {
        let dir = tempdir("readonly");
        let dest = dir.join("a.png");
        std::fs::write(&dest, b"keep").unwrap();
        let mut perms = std::fs::metadata(&dest).unwrap().permissions();
        perms.set_readonly(true);
        std::fs::set_permissions(&dest, perms.clone()).unwrap();
        let e = format!("{:#}", PendingFile::create(&dest).err().unwrap());
        assert!(e.ends_with("a.png: the file is read-only"), "{e}");
        assert_eq!(std::fs::read(&dest).unwrap(), b"keep");
        #[allow(clippy::permissions_set_readonly_false)]
        perms.set_readonly(false);
        std::fs::set_permissions(&dest, perms).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn dev_full_reports_the_error_and_stays_a_device() {
        use std::os::unix::fs::FileTypeExt as _;
        let mut p = PendingFile::create(Path::new("/dev/full")).unwrap();
        let e = format!("{:#}", p.write_bytes(b"x").unwrap_err());
        assert!(e.starts_with("/dev/full: write failed"), "{e}");
        let m = std::fs::symlink_metadata("/dev/full").unwrap();
        assert!(m.file_type().is_char_device());
    }

    #[cfg(unix)]
    #[test]
    fn fifo_is_written_into() {
        use std::os::unix::fs::FileTypeExt as _;
        let dir = tempdir("fifo");
        let fifo = dir.join("f");
        let ok = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            return;
        }
        // Creating must not open the FIFO: with no reader yet that would block.
        let mut p = PendingFile::create(&fifo).unwrap();
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        p.write_bytes(b"through").unwrap();
        p.commit().unwrap();
        assert_eq!(reader.join().unwrap(), b"through");
        let m = std::fs::symlink_metadata(&fifo).unwrap();
        assert!(m.file_type().is_fifo());
        assert!(partials(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn interrupt_cleanup_removes_registered_partials() {
        let dir = tempdir("interrupt");
        let mut p = PendingFile::create(&dir.join("a.png")).unwrap();
        p.write_bytes(b"partial").unwrap();
        let Sink::Replace { tmp, .. } = &p.sink else {
            panic!("a new file is written through a temporary file")
        };
        let tmp = tmp.clone();
        assert!(tmp.exists());
        {
            let mut reg = registry();
            // Other tests may have partial files registered at the same time.
            let mut mine: Vec<PathBuf> = reg.iter().filter(|t| **t == tmp).cloned().collect();
            reg.retain(|t| *t != tmp);
            assert_eq!(remove_partial_files(&mut mine), 1);
        }
        assert!(!tmp.exists());
        // Drop after the handler's cleanup must not fail or touch anything else.
        drop(p);
        assert!(partials(&dir).is_empty() && !dir.join("a.png").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
