//! Messages for the user: what the library assumed or found, without naming any
//! front end's options (the command-line tool prefixes its flag, Python shows the text).

/// What a note is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoteTopic {
    /// The camera chosen for frames without a calibration (EXIF or generic).
    Camera,
    /// A calibration the caller gave, used as given but worth saying (a field of view no
    /// real lens has, extrinsics on the first camera).
    Calibration,
    /// Measuring the hand's size over the first frames.
    HandScale,
    /// Learning each side's hand proportions over the first frames.
    Proportions,
    /// The outputs.
    Output,
}

/// One message for the user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    /// What it is about.
    pub topic: NoteTopic,
    /// The message.
    pub message: String,
}

impl Note {
    pub(crate) fn new(topic: NoteTopic, message: impl Into<String>) -> Note {
        Note {
            topic,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for Note {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}
