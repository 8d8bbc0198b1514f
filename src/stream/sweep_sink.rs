//! Opening a sink with a fixed recording id: every part of one sweep (`wisptree sweep --only K
//! --save part-K.rrd`) writes the same recording, so `rerun rrd merge` joins them into one.

use anyhow::Context as _;

use super::sink::{open_sink, OpenSink, Recording, SinkChoice, APP_ID};

/// Opens `choice` as [`open_sink`] does, with recording id `recording_id` for a file or
/// standard output (the sinks whose parts are merged later). A live viewer gets a fresh id, as
/// from [`open_sink`]: it shows what it is sent, and nothing is merged afterwards.
pub fn open_sink_with_id(choice: &SinkChoice, recording_id: &str) -> anyhow::Result<OpenSink> {
    let builder = || rerun::RecordingStreamBuilder::new(APP_ID).recording_id(recording_id);
    match choice {
        SinkChoice::Save(path) => {
            super::sink::prepare_save_path(path)?;
            let rec = builder()
                .save(path)
                .with_context(|| format!("{}: cannot create the recording", path.display()))?;
            let mut s = OpenSink::recording(Recording(rec));
            s.file = Some(path.clone());
            s.description = format!("file {}", path.display());
            Ok(s)
        }
        SinkChoice::Stdout => {
            let rec = builder()
                .stdout()
                .context("opening standard output for the recording")?;
            let mut s = OpenSink::recording(Recording(rec));
            s.description = "standard output".to_owned();
            Ok(s)
        }
        other => open_sink(other),
    }
}

/// An in-memory recording with recording id `recording_id` (tests).
pub fn memory_with_id(
    recording_id: &str,
) -> anyhow::Result<(Recording, super::sink::MemoryRecording)> {
    let (rec, storage) = rerun::RecordingStreamBuilder::new(APP_ID)
        .recording_id(recording_id)
        .memory()
        .context("creating an in-memory recording")?;
    Ok((Recording(rec), super::sink::MemoryRecording(storage)))
}
