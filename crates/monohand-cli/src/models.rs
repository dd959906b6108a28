//! `monohand models`: fetch and inspect the cached MediaPipe weights.

use crate::vision::ModelArgs;
use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use monohand_vision::ModelFile;

/// Arguments of `monohand models`.
#[derive(Debug, Args)]
pub(crate) struct ModelsArgs {
    #[command(subcommand)]
    pub action: ModelsAction,
    #[command(flatten)]
    pub models: ModelArgs,
}

/// What `monohand models` does.
#[derive(Debug, Subcommand)]
pub(crate) enum ModelsAction {
    /// Download the mediapipe==0.10.14 wheel with pip (or read $MONOHAND_MEDIAPIPE_WHEEL),
    /// extract the networks and their license into the cache and verify their SHA-256 sums.
    /// Other commands do this on first use; run it once to prepare an offline machine.
    Fetch,
    /// Print the cache folder and whether each network in it is present and intact.
    List,
}

pub(crate) fn run(args: &ModelsArgs) -> Result<()> {
    let store = args.models.store()?;
    match args.action {
        ModelsAction::Fetch => {
            store.fetch()?;
            println!("MediaPipe networks ready in {}", store.dir().display());
            Ok(())
        }
        ModelsAction::List => {
            println!("cache: {}", store.dir().display());
            let mut missing = 0;
            for file in ModelFile::ALL {
                let ok = store.is_valid(file);
                missing += usize::from(!ok);
                println!(
                    "  {:<36} {}  sha256 {}",
                    file.file_name(),
                    if ok { "ok     " } else { "missing" },
                    file.sha256()
                );
            }
            if missing > 0 {
                bail!("{missing} network file(s) missing or corrupt: run `monohand models fetch`");
            }
            Ok(())
        }
    }
}
