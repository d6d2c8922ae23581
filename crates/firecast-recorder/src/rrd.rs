//! A deterministic `.rrd` writer: the same rows logged in the same order give the same bytes.
//!
//! Rerun's `RecordingStream` puts a random recording id, time-based row and chunk ids
//! (TUIDs), `log_time` and the recording's start time into a file, and batches rows into
//! chunks on a timer; none of that repeats from one run to the next. This writer builds the
//! chunks itself and hands them to Rerun's own encoder (the one its file sink uses): row and
//! chunk ids count up from seeds derived from the store id, rows are batched by entity,
//! timelines and components and cut by size only, and no wall-clock time is written. The
//! footer (the manifest readers use for random access) is built as Rerun's encoder builds
//! it, except that its schema's fields are sorted: Rerun collects them in a `HashMap`, whose
//! order changes from one run to the next.

use std::collections::HashMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use rerun::external::arrow::datatypes::{DataType, Schema};
use rerun::external::re_log_encoding::{
    CrateVersion, EncodeError, Encoder, EncodingOptions, RrdFooter, RrdManifestBuilder, ToTransport as _,
};
use rerun::external::re_log_types::external::re_tuid::Tuid;
use rerun::external::re_log_types::{SetStoreInfo, StoreInfo, StoreSource};
use rerun::log::{Chunk, ChunkId, LogMsg, RowId};
use rerun::time::TimeType;
use rerun::{ComponentDescriptor, EntityPath, SerializedComponentBatch, StoreId, TimePoint, TimelineName};

use crate::RecorderError;

/// A pending chunk is written once its rows hold this many bytes or this many rows (Rerun's
/// batcher defaults, without its 200 ms timer), and every pending chunk once they all hold
/// [`PENDING_MAX_BYTES`] (many small series, e.g. metrics, stay bounded in memory). Sizes
/// are the data's own (not buffer capacities or struct sizes, which a build may change)
/// plus [`ROW_BYTES`] per row for its ids, times and descriptors.
const CHUNK_MAX_BYTES: u64 = 2 * 1024 * 1024;
const CHUNK_MAX_ROWS: usize = 8192;
const PENDING_MAX_BYTES: u64 = 16 * 1024 * 1024;
const ROW_BYTES: u64 = 256;

/// What Rerun's file sink writes: Protobuf, LZ4.
const OPTIONS: EncodingOptions = EncodingOptions::PROTOBUF_COMPRESSED;

/// Written as the store's source instead of the Rust SDK's, which names the rustc and LLVM
/// that built the binary (two builds would then write different bytes).
const STORE_SOURCE: &str = "firecast";

/// FNV-1a over `parts` (each followed by a 0 byte), then splitmix64 per output word: a hash
/// that is the same on every platform and Rust release (std's is not promised to be).
fn stable_words<const N: usize>(parts: &[&str]) -> [u64; N] {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for b in part.bytes().chain([0]) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    let mut out = [0; N];
    for word in &mut out {
        h = h.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = h;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        *word = z ^ (z >> 31);
    }
    out
}

/// A recording id (UUID-shaped, like Rerun's random ones) that depends only on the
/// application and the recording's name.
pub(crate) fn derived_recording_id(application_id: &str, recording_name: &str) -> String {
    let [a, b] = stable_words::<2>(&["firecast recording id", application_id, recording_name]);
    let hex = format!("{a:016x}{b:016x}");
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..]
    )
}

/// Row and chunk ids: TUIDs without a time (0 ns) whose increments start at seeds from the
/// store id, so recordings opened side by side in a viewer do not share ids.
struct Ids {
    next_row: u64,
    next_chunk: u64,
}

impl Ids {
    fn new(store_id: &StoreId) -> Self {
        // Top bit clear, as Rerun leaves it, so counting up never wraps.
        let [row, chunk] = stable_words::<2>(&[
            "firecast tuids",
            store_id.application_id().as_str(),
            store_id.recording_id().as_str(),
        ])
        .map(|w| w & !(1 << 63));
        Self {
            next_row: row,
            next_chunk: chunk,
        }
    }

    fn tuid(counter: &mut u64) -> Tuid {
        *counter += 1;
        Tuid::from_nanos_and_inc(0, *counter)
    }

    fn row(&mut self) -> RowId {
        RowId::from_tuid(Self::tuid(&mut self.next_row))
    }

    fn chunk(&mut self) -> ChunkId {
        ChunkId::from_tuid(Self::tuid(&mut self.next_chunk))
    }
}

/// What rows must share to go into one chunk.
#[derive(PartialEq)]
struct ChunkKey {
    entity_path: EntityPath,
    timelines: Vec<(TimelineName, TimeType)>,
    components: Vec<(ComponentDescriptor, DataType)>,
}

struct Row {
    id: RowId,
    timepoint: TimePoint,
    components: Vec<SerializedComponentBatch>,
}

struct Pending {
    key: ChunkKey,
    rows: Vec<Row>,
    bytes: u64,
}

/// An `.rrd` file being written.
pub(crate) struct RrdWriter {
    path: PathBuf,
    store_id: StoreId,
    ids: Ids,
    encoder: Encoder<BufWriter<File>>,
    /// The footer's manifest, once a chunk is written (as Rerun's encoder does).
    manifest: Option<RrdManifestBuilder>,
    /// Rows not yet written, one batch per [`ChunkKey`], oldest first.
    pending: Vec<Pending>,
    /// The sum of their sizes.
    pending_bytes: u64,
}

impl RrdWriter {
    /// Creates `path` and writes the store info and the recording's name.
    pub(crate) fn create(
        path: &Path,
        store_id: StoreId,
        recording_name: &str,
    ) -> Result<Self, RecorderError> {
        let file = File::create(path).map_err(|source| RecorderError::Io {
            context: "cannot create recording",
            path: path.to_path_buf(),
            source,
        })?;
        let mut encoder = Encoder::new_eager(CrateVersion::LOCAL, OPTIONS, BufWriter::new(file))
            .map_err(|e| write_error(path, e))?;
        // The footer is ours (see `finish`).
        encoder.do_not_emit_footer();
        let mut ids = Ids::new(&store_id);
        let store_info = SetStoreInfo {
            row_id: ids.row().as_tuid(),
            info: StoreInfo::new(store_id.clone(), StoreSource::Other(STORE_SOURCE.into())),
        };
        let mut writer = Self {
            path: path.to_path_buf(),
            store_id,
            ids,
            encoder,
            manifest: None,
            pending: Vec::new(),
            pending_bytes: 0,
        };
        writer.append(&LogMsg::SetStoreInfo(store_info), None)?;
        // The name only: Rerun's default properties also carry the wall-clock start time.
        let info = rerun::RecordingInfo::new().with_name(recording_name);
        writer.push(
            EntityPath::properties(),
            TimePoint::default(),
            rerun::AsComponents::as_serialized_batches(&info),
        )?;
        writer.flush_all()?;
        Ok(writer)
    }

    /// Writes a message; a chunk also goes into the footer's manifest.
    #[allow(unsafe_code)]
    fn append(&mut self, msg: &LogMsg, chunk: Option<&Chunk>) -> Result<(), RecorderError> {
        let transport = msg
            .to_transport(OPTIONS.compression)
            .map_err(|e| write_error(&self.path, e.into()))?;
        // SAFETY: not about memory; the message must be encoded with the encoder's
        // compression, and it is (`OPTIONS` for both).
        let (span, uncompressed) = unsafe { self.encoder.append_transport_without_footer(&transport) }
            .map_err(|e| write_error(&self.path, e))?;
        if let Some(chunk) = chunk {
            let batch = chunk
                .to_chunk_batch()
                .map_err(|e| write_error(&self.path, e.into()))?;
            self.manifest
                .get_or_insert_default()
                .append(&batch, span, uncompressed)
                .map_err(|e| write_error(&self.path, e.into()))?;
        }
        Ok(())
    }

    /// Adds one row at `timepoint` (empty: static); rows with no component are dropped, as
    /// Rerun does.
    pub(crate) fn push(
        &mut self,
        entity_path: EntityPath,
        timepoint: TimePoint,
        batches: Vec<SerializedComponentBatch>,
    ) -> Result<(), RecorderError> {
        // One batch per component, the last one logged winning (as in Rerun), in a fixed order.
        let mut components: Vec<SerializedComponentBatch> = Vec::with_capacity(batches.len());
        for batch in batches {
            components.retain(|c| c.descriptor.component != batch.descriptor.component);
            components.push(batch);
        }
        if components.is_empty() {
            return Ok(());
        }
        components.sort_by(|a, b| a.descriptor.cmp(&b.descriptor));
        let key = ChunkKey {
            entity_path,
            timelines: timepoint.iter().map(|(name, cell)| (*name, cell.typ())).collect(),
            components: components
                .iter()
                .map(|c| (c.descriptor.clone(), c.array.data_type().clone()))
                .collect(),
        };
        let bytes = ROW_BYTES
            + components
                .iter()
                .map(|c| {
                    let data = c.array.to_data();
                    data.get_slice_memory_size()
                        .unwrap_or_else(|_| data.get_buffer_memory_size()) as u64
                })
                .sum::<u64>();
        let row = Row {
            id: self.ids.row(),
            timepoint,
            components,
        };
        let index = match self.pending.iter().position(|p| p.key == key) {
            Some(index) => index,
            None => {
                self.pending.push(Pending {
                    key,
                    rows: Vec::new(),
                    bytes: 0,
                });
                self.pending.len() - 1
            }
        };
        let pending = &mut self.pending[index];
        pending.rows.push(row);
        pending.bytes += bytes;
        self.pending_bytes += bytes;
        if pending.bytes >= CHUNK_MAX_BYTES || pending.rows.len() >= CHUNK_MAX_ROWS {
            let pending = self.pending.remove(index);
            self.pending_bytes -= pending.bytes;
            self.write_chunk(pending)?;
        } else if self.pending_bytes >= PENDING_MAX_BYTES {
            self.flush_all()?;
        }
        Ok(())
    }

    fn write_chunk(&mut self, pending: Pending) -> Result<(), RecorderError> {
        let Pending { key, rows, .. } = pending;
        let mut builder = Chunk::builder_with_id(self.ids.chunk(), key.entity_path);
        for row in rows {
            builder = builder.with_serialized_batches(row.id, row.timepoint, row.components);
        }
        let chunk = builder.build().map_err(|e| RecorderError::Log(e.to_string()))?;
        let msg = chunk
            .to_arrow_msg()
            .map_err(|e| RecorderError::Log(e.to_string()))?;
        self.append(&LogMsg::ArrowMsg(self.store_id.clone(), msg), Some(&chunk))
    }

    fn flush_all(&mut self) -> Result<(), RecorderError> {
        self.pending_bytes = 0;
        for pending in std::mem::take(&mut self.pending) {
            self.write_chunk(pending)?;
        }
        Ok(())
    }

    /// Writes what is pending, the footer and the end marker, and closes the file.
    #[allow(unsafe_code)]
    pub(crate) fn finish(mut self) -> Result<(), RecorderError> {
        self.flush_all()?;
        let path = self.path.clone();
        let mut footer = RrdFooter::default();
        if let Some(builder) = self.manifest.take() {
            let mut manifest = builder
                .build(self.store_id.clone())
                .map_err(|e| write_error(&path, e.into()))?;
            // Field names are unique (Rerun's keys). The schema's hash is order-free already.
            let mut fields: Vec<_> = manifest.sorbet_schema.fields().iter().cloned().collect();
            fields.sort_by(|a, b| a.name().cmp(b.name()));
            manifest.sorbet_schema =
                Schema::new_with_metadata(fields, manifest.sorbet_schema.metadata().clone());
            footer.manifests = HashMap::from([(self.store_id.clone(), manifest)]);
        }
        // SAFETY: not about memory; the footer must describe the stream, and it is the one
        // Rerun's encoder builds from the same messages (checked by `rerun rrd verify` in
        // the tests).
        unsafe { self.encoder.finish_with_custom_footer(&footer) }.map_err(|e| write_error(&path, e))?;
        let buffered = self.encoder.into_inner().map_err(|e| write_error(&path, e))?;
        buffered
            .into_inner()
            .map_err(|e| RecorderError::Io {
                context: "cannot write recording",
                path: path.clone(),
                source: e.into_error(),
            })?
            .sync_all()
            .map_err(|source| RecorderError::Io {
                context: "cannot write recording",
                path,
                source,
            })
    }

    /// Stops writing; the caller removes the file.
    pub(crate) fn abandon(self) {
        // Without a footer, dropping the encoder writes nothing more.
        drop(self.encoder.into_inner());
    }
}

fn write_error(path: &Path, e: EncodeError) -> RecorderError {
    RecorderError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::{derived_recording_id, stable_words};

    #[test]
    fn derived_ids_are_stable_and_distinct() {
        // Pinned: a change here changes the bytes of every recording (and every lockfile).
        assert_eq!(
            derived_recording_id("firecast_test", "same twice"),
            "35e03f73-4cf0-0f75-3703-1f98e85077cf"
        );
        assert_ne!(
            derived_recording_id("firecast_helitack", "rule agent, seed 5"),
            derived_recording_id("firecast_helitack", "rule agent, seed 6")
        );
        assert_ne!(stable_words::<1>(&["ab", "c"]), stable_words::<1>(&["a", "bc"]));
    }
}
