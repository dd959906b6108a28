//! The pretrained networks: which files, where they come from, where they are cached, and
//! their pinned SHA-256 sums.
//!
//! The weights ship inside the PyPI wheel `mediapipe==0.10.14` (Apache-2.0; later wheels no
//! longer contain them). [`ModelStore::fetch`] runs
//! `pip download --no-deps --only-binary=:all: --platform manylinux_2_17_x86_64 --python-version 3.11 mediapipe==0.10.14`
//! into a temporary folder, opens the wheel as a zip, extracts only the `.tflite` files listed
//! in [`ModelFile`] plus the wheel's license, checks every file against the SHA-256 sums
//! pinned here and moves them into the cache directory. Nothing is installed.
//!
//! Cache directory, first match wins: the `dir` given to [`ModelStore::new`], the environment
//! variable [`MODEL_DIR_ENV`], `$XDG_CACHE_HOME/monohand/models`, `$HOME/.cache/monohand/models`.
//! Offline machines can point [`WHEEL_ENV`] at a wheel downloaded elsewhere.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

use sha2::{Digest, Sha256};

use crate::error::{Result, VisionError};

/// Environment variable overriding the model cache directory.
pub const MODEL_DIR_ENV: &str = "MONOHAND_MODEL_DIR";
/// Environment variable naming an already-downloaded `mediapipe-0.10.14-*.whl` to extract
/// from instead of calling pip.
pub const WHEEL_ENV: &str = "MONOHAND_MEDIAPIPE_WHEEL";
/// The pinned wheel.
pub const MEDIAPIPE_REQUIREMENT: &str = "mediapipe==0.10.14";
/// Name the wheel's license gets in the cache directory, beside the weights.
pub const LICENSE_FILE: &str = "LICENSE.mediapipe.txt";

/// One network file from the MediaPipe wheel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModelFile {
    /// Palm detector, full variant (192x192 input).
    PalmDetectionFull,
    /// Palm detector, lite variant.
    PalmDetectionLite,
    /// 21-landmark hand model, full variant (224x224 input).
    HandLandmarkFull,
    /// 21-landmark hand model, lite variant.
    HandLandmarkLite,
    /// BlazeFace short-range face detector (128x128 input), used for head boxes.
    FaceDetectionShortRange,
}

impl ModelFile {
    /// Every file the crate knows.
    pub const ALL: [ModelFile; 5] = [
        ModelFile::PalmDetectionFull,
        ModelFile::PalmDetectionLite,
        ModelFile::HandLandmarkFull,
        ModelFile::HandLandmarkLite,
        ModelFile::FaceDetectionShortRange,
    ];

    /// Path of the file inside the wheel.
    pub fn wheel_path(self) -> &'static str {
        match self {
            ModelFile::PalmDetectionFull => {
                "mediapipe/modules/palm_detection/palm_detection_full.tflite"
            }
            ModelFile::PalmDetectionLite => {
                "mediapipe/modules/palm_detection/palm_detection_lite.tflite"
            }
            ModelFile::HandLandmarkFull => {
                "mediapipe/modules/hand_landmark/hand_landmark_full.tflite"
            }
            ModelFile::HandLandmarkLite => {
                "mediapipe/modules/hand_landmark/hand_landmark_lite.tflite"
            }
            ModelFile::FaceDetectionShortRange => {
                "mediapipe/modules/face_detection/face_detection_short_range.tflite"
            }
        }
    }

    /// File name in the cache directory.
    pub fn file_name(self) -> &'static str {
        self.wheel_path()
            .rsplit('/')
            .next()
            .unwrap_or(self.wheel_path())
    }

    /// Whether `bytes` are this file: its pinned checksum, else [`VisionError::Checksum`]
    /// naming `origin` (where the bytes came from).
    pub fn check(self, bytes: &[u8], origin: &Path) -> Result<()> {
        let found = sha256_hex(bytes);
        if found != self.sha256() {
            return Err(VisionError::Checksum {
                path: origin.into(),
                expected: self.sha256().into(),
                found,
            });
        }
        Ok(())
    }

    /// Pinned SHA-256 of the file (lower-case hex), computed from the 0.10.14 wheel.
    pub fn sha256(self) -> &'static str {
        match self {
            ModelFile::PalmDetectionFull => {
                "1b14e9422c6ad006cde6581a46c8b90dd573c07ab7f3934b5589e7cea3f89a54"
            }
            ModelFile::PalmDetectionLite => {
                "e9a4aaddf90dda56a87235303cf00e4c2d3fb28725f68fd88772997dac905c18"
            }
            ModelFile::HandLandmarkFull => {
                "11c272b891e1a99ab034208e23937a8008388cf11ed2a9d776ed3d01d0ba00e3"
            }
            ModelFile::HandLandmarkLite => {
                "048edd3645c9bf7397d19a9f6e3a42957d6e414c9bea6598030a2e9b624156e6"
            }
            ModelFile::FaceDetectionShortRange => {
                "bbff11cebd1eb27a1e004cae0b0e63ec8c551cbf34a4451148b4908b8db3eca8"
            }
        }
    }
}

/// The command a user can run by hand to fetch the wheel, quoted in error messages.
pub fn manual_fetch_hint() -> String {
    format!(
        "run `pip download --no-deps --only-binary=:all: --platform manylinux_2_17_x86_64 \
         --python-version 3.11 {MEDIAPIPE_REQUIREMENT} -d /tmp/mp` on a machine with network \
         access, then set {WHEEL_ENV}=/tmp/mp/mediapipe-0.10.14-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl \
         (or run `monohand models fetch` once pip and the network are available)"
    )
}

/// Serialises fetches inside one process (tests run in parallel threads).
static FETCH_LOCK: Mutex<()> = Mutex::new(());

/// The local cache of network files.
#[derive(Clone, Debug)]
pub struct ModelStore {
    dir: PathBuf,
}

impl ModelStore {
    /// A store in `dir`, or in the default location (see the module docs) when `None`.
    pub fn new(dir: Option<PathBuf>) -> Result<Self> {
        let dir = match dir {
            Some(d) => d,
            None => default_dir()?,
        };
        Ok(ModelStore { dir })
    }

    /// The cache directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Path where `file` lives (or will live) in the cache.
    pub fn path_of(&self, file: ModelFile) -> PathBuf {
        self.dir.join(file.file_name())
    }

    /// Whether `file` is present with the pinned checksum.
    pub fn is_valid(&self, file: ModelFile) -> bool {
        std::fs::read(self.path_of(file))
            .map(|b| sha256_hex(&b) == file.sha256())
            .unwrap_or(false)
    }

    /// The bytes of `file`, fetching the wheel first if the file is missing. The checksum is
    /// verified on every load; a cached file that fails it (damaged on disk, a copy cut
    /// short) is fetched again once, automatically, with a warning, and is an error only
    /// if the fresh copy fails too.
    pub fn load(&self, file: ModelFile) -> Result<Vec<u8>> {
        self.load_with(file, || self.fetch())
    }

    /// [`ModelStore::load`] with the fetch step given (the tests' seam).
    fn load_with(&self, file: ModelFile, fetch: impl Fn() -> Result<()>) -> Result<Vec<u8>> {
        let path = self.path_of(file);
        if !path.exists() {
            fetch()?;
        }
        let read = || {
            let bytes = std::fs::read(&path).map_err(|source| VisionError::Io {
                path: path.clone(),
                source,
            })?;
            let found = sha256_hex(&bytes);
            Ok::<_, VisionError>((bytes, found))
        };
        let (bytes, found) = read()?;
        if found == file.sha256() {
            return Ok(bytes);
        }
        tracing::warn!(
            "{}: checksum mismatch (expected {}, found {found}); fetching the networks again",
            path.display(),
            file.sha256()
        );
        fetch().map_err(|e| {
            VisionError::ModelFetch(format!(
                "{} failed its checksum and fetching it again failed: {e}",
                path.display()
            ))
        })?;
        let (bytes, _) = read()?;
        file.check(&bytes, &path)?;
        Ok(bytes)
    }

    /// Makes sure every file of [`ModelFile::ALL`] is in the cache with the right checksum,
    /// downloading the wheel with pip (or reading [`WHEEL_ENV`]) if needed.
    pub fn fetch(&self) -> Result<()> {
        let _guard = FETCH_LOCK.lock().unwrap_or_else(|p| p.into_inner());
        if ModelFile::ALL.iter().all(|&f| self.is_valid(f)) && self.dir.join(LICENSE_FILE).exists()
        {
            return Ok(());
        }
        std::fs::create_dir_all(&self.dir).map_err(|source| VisionError::Io {
            path: self.dir.clone(),
            source,
        })?;
        if let Some(wheel) = std::env::var_os(WHEEL_ENV) {
            return self.extract_wheel(Path::new(&wheel));
        }
        let tmp = self.dir.join(format!(".download-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp).map_err(|source| VisionError::Io {
            path: tmp.clone(),
            source,
        })?;
        let result = pip_download(&tmp).and_then(|wheel| self.extract_wheel(&wheel));
        let _ = std::fs::remove_dir_all(&tmp);
        result
    }

    /// Extracts the known model files and the license from a mediapipe wheel into the cache,
    /// verifying each against its pinned checksum before it is moved into place.
    pub fn extract_wheel(&self, wheel: &Path) -> Result<()> {
        let file = std::fs::File::open(wheel).map_err(|source| VisionError::Io {
            path: wheel.into(),
            source,
        })?;
        let mut zip = zip::ZipArchive::new(file).map_err(|e| {
            VisionError::ModelFetch(format!("{} is not a wheel (zip): {e}", wheel.display()))
        })?;
        std::fs::create_dir_all(&self.dir).map_err(|source| VisionError::Io {
            path: self.dir.clone(),
            source,
        })?;
        for model in ModelFile::ALL {
            let bytes = read_entry(&mut zip, model.wheel_path())?;
            let found = sha256_hex(&bytes);
            if found != model.sha256() {
                return Err(VisionError::Checksum {
                    path: wheel.join(model.wheel_path()),
                    expected: model.sha256().into(),
                    found,
                });
            }
            write_atomically(&self.path_of(model), &bytes)?;
        }
        let license_name = zip
            .file_names()
            .find(|n| n.ends_with(".dist-info/LICENSE"))
            .map(str::to_string)
            .ok_or_else(|| VisionError::ModelFetch("the wheel has no LICENSE file".into()))?;
        let license = read_entry(&mut zip, &license_name)?;
        let mut notice = format!(
            "The .tflite files in this directory were extracted unmodified from the PyPI wheel \
             {MEDIAPIPE_REQUIREMENT} (Google MediaPipe) and are distributed under the Apache \
             License 2.0 reproduced below.\n\n"
        )
        .into_bytes();
        notice.extend_from_slice(&license);
        write_atomically(&self.dir.join(LICENSE_FILE), &notice)
    }
}

fn read_entry(zip: &mut zip::ZipArchive<std::fs::File>, name: &str) -> Result<Vec<u8>> {
    let mut entry = zip
        .by_name(name)
        .map_err(|e| VisionError::ModelFetch(format!("{name} not found in the wheel: {e}")))?;
    let mut bytes = Vec::with_capacity(entry.size() as usize);
    entry
        .read_to_end(&mut bytes)
        .map_err(|e| VisionError::ModelFetch(format!("cannot read {name} from the wheel: {e}")))?;
    Ok(bytes)
}

fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension(format!("part{}", std::process::id()));
    let io = |source| VisionError::Io {
        path: path.into(),
        source,
    };
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// The default cache directory (see the module docs).
pub fn default_dir() -> Result<PathBuf> {
    if let Some(d) = std::env::var_os(MODEL_DIR_ENV).filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(d).join("monohand").join("models"));
    }
    if let Some(h) = std::env::var_os("HOME").filter(|d| !d.is_empty()) {
        return Ok(PathBuf::from(h)
            .join(".cache")
            .join("monohand")
            .join("models"));
    }
    Err(VisionError::ModelFetch(format!(
        "no cache directory: set {MODEL_DIR_ENV}, XDG_CACHE_HOME or HOME"
    )))
}

/// The ways pip is looked for, in order.
const PIP_COMMANDS: [(&str, &[&str]); 4] = [
    ("python3", &["-m", "pip"]),
    ("python", &["-m", "pip"]),
    ("pip3", &[]),
    ("pip", &[]),
];

/// Runs pip to download the wheel into `dir`, returning the wheel's path.
fn pip_download(dir: &Path) -> Result<PathBuf> {
    pip_download_with(dir, &PIP_COMMANDS)
}

fn pip_download_with(dir: &Path, candidates: &[(&str, &[&str])]) -> Result<PathBuf> {
    let args = [
        "download",
        "--no-deps",
        "--only-binary=:all:",
        "--platform",
        "manylinux_2_17_x86_64",
        "--python-version",
        "3.11",
        "--implementation",
        "cp",
        "--abi",
        "cp311",
        "--disable-pip-version-check",
        "--quiet",
        MEDIAPIPE_REQUIREMENT,
        "-d",
    ];
    let mut tried = Vec::new();
    for &(program, prefix) in candidates {
        let output = Command::new(program)
            .args(prefix)
            .args(args)
            .arg(dir)
            .output();
        match output {
            Err(e) => tried.push(format!("{program}: {e}")),
            Ok(out) if out.status.success() => {
                let wheel = std::fs::read_dir(dir)
                    .map_err(|source| VisionError::Io {
                        path: dir.into(),
                        source,
                    })?
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .find(|p| p.extension().is_some_and(|x| x == "whl"));
                return wheel.ok_or_else(|| {
                    VisionError::ModelFetch(format!(
                        "pip reported success but left no wheel in {}",
                        dir.display()
                    ))
                });
            }
            Ok(out) => {
                let stderr = String::from_utf8_lossy(&out.stderr);
                let last = stderr
                    .lines()
                    .rev()
                    .find(|l| !l.trim().is_empty())
                    .unwrap_or("")
                    .trim();
                tried.push(format!("{program} {}: {last}", prefix.join(" ")));
            }
        }
    }
    Err(VisionError::ModelFetch(format!(
        "could not download {MEDIAPIPE_REQUIREMENT} with pip ({}). To fix: {}",
        tried.join("; "),
        manual_fetch_hint()
    )))
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_known_string() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn file_names_are_the_wheel_basenames() {
        assert_eq!(
            ModelFile::HandLandmarkFull.file_name(),
            "hand_landmark_full.tflite"
        );
        assert_eq!(
            ModelFile::FaceDetectionShortRange.file_name(),
            "face_detection_short_range.tflite"
        );
    }

    #[test]
    fn explicit_dir_wins() {
        let s = ModelStore::new(Some(PathBuf::from("/x/y"))).expect("store");
        assert_eq!(
            s.path_of(ModelFile::PalmDetectionLite),
            PathBuf::from("/x/y/palm_detection_lite.tflite")
        );
    }

    #[test]
    fn missing_pip_says_what_to_run() {
        let dir = std::env::temp_dir().join(format!("monohand-nopip-{}", std::process::id()));
        let e = pip_download_with(&dir, &[("monohand-no-such-python", &["-m", "pip"])])
            .expect_err("no pip");
        let msg = e.to_string();
        assert!(msg.contains("pip download --no-deps"), "{msg}");
        assert!(msg.contains(WHEEL_ENV), "{msg}");
        assert!(matches!(e, VisionError::ModelFetch(_)));
    }

    #[test]
    fn a_corrupt_cached_file_is_fetched_again_once() {
        let dir = tempfile::tempdir().expect("tmp");
        let s = ModelStore::new(Some(dir.path().to_path_buf())).expect("store");
        let file = ModelFile::PalmDetectionFull;
        std::fs::write(s.path_of(file), b"not a model").expect("write");
        // The fetch cannot repair it: one attempt, then the checksum error.
        let calls = std::cell::Cell::new(0);
        let err = s
            .load_with(file, || {
                calls.set(calls.get() + 1);
                Ok(())
            })
            .expect_err("must fail");
        assert!(matches!(err, VisionError::Checksum { .. }), "{err}");
        assert_eq!(calls.get(), 1, "fetched again exactly once");
        // A fetch that fails is reported with the reason.
        let err = s
            .load_with(file, || Err(VisionError::ModelFetch("offline".into())))
            .expect_err("must fail");
        let msg = err.to_string();
        assert!(
            msg.contains("failed its checksum and fetching it again failed: ")
                && msg.contains("offline"),
            "{msg}"
        );
    }
}
