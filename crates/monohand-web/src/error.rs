//! What can go wrong in the browser build, said so that the page can show it as it is.

/// Everything the browser build can refuse or fail at.
#[derive(Debug, thiserror::Error)]
pub enum WebError {
    /// A weights file is not the network it should be (missing: an empty body or a server's
    /// error page; damaged; another network).
    #[error(
        "the {what} weights ({bytes} bytes, SHA-256 {found}) are not one of {expected}: \
         copy them again with scripts/web-build.sh (from `monohand models fetch`'s cache)"
    )]
    Weights {
        /// Which network: "palm detector" or "hand landmark".
        what: &'static str,
        /// Size of what was given.
        bytes: usize,
        /// Its SHA-256.
        found: String,
        /// The files it may be, by name.
        expected: String,
    },
    /// The options are not valid JSON of the expected shape, or impossible.
    #[error("invalid options: {0}")]
    Options(String),
    /// A frame whose pixels do not match its size.
    #[error("bad frame: {0}")]
    Frame(String),
    /// The networks or the session failed.
    #[error(transparent)]
    Session(#[from] monohand::SessionError),
    /// A record could not be written as JSON (a non-finite number).
    #[error(transparent)]
    Record(#[from] monohand_io::IoError),
}
