//! Buffer creation, upload and readback.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

use crate::{GpuContext, GpuError, context::error_text};

/// Staging size used by [`GpuContext::read_buffer`]: readbacks larger than this go through the same staging
/// buffer in several copy-map-unmap rounds, so a readback never needs more than this much extra memory.
pub const READBACK_CHUNK_BYTES: u64 = 64 << 20;

/// `bytes` rounded up to a multiple of `to` (`to` > 0).
fn round_up(bytes: u64, to: u64) -> u64 {
    bytes.div_ceil(to) * to
}

impl GpuContext {
    fn check_buffer_size(&self, label: &str, bytes: u64) -> Result<(), GpuError> {
        if bytes > self.limits.max_buffer_size {
            return Err(GpuError::BufferTooLarge { label: label.to_owned(), bytes, max: self.limits.max_buffer_size });
        }
        Ok(())
    }

    /// A storage buffer holding `data` (usage `STORAGE | COPY_SRC | COPY_DST`), for `var<storage, read>` or
    /// `var<storage, read_write>` bindings, readable with [`GpuContext::read_buffer`].
    ///
    /// The buffer size is `size_of_val(data)` rounded up to a multiple of 4 bytes and at least 4 (zero-sized
    /// bindings are invalid); the padding is zero. Keep the element count yourself.
    ///
    /// # Errors
    /// [`GpuError::BufferTooLarge`] beyond `max_buffer_size`; [`GpuError::Operation`] if wgpu fails (out of
    /// memory). A binding of the whole buffer must also fit [`GpuContext::max_storage_binding_bytes`]; if it
    /// does not, bind chunks (see [`crate::split_for_binding`]).
    pub fn create_storage_buffer<T: Pod>(&self, label: &str, data: &[T]) -> Result<wgpu::Buffer, GpuError> {
        self.create_buffer_with_data(label, bytemuck::cast_slice(data), 4, wgpu::BufferUsages::empty())
    }

    /// As [`GpuContext::create_storage_buffer`], with extra usages (e.g. `VERTEX`, `INDIRECT`) added.
    ///
    /// # Errors
    /// As [`GpuContext::create_storage_buffer`].
    pub fn create_storage_buffer_with_usage<T: Pod>(
        &self,
        label: &str,
        data: &[T],
        extra_usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        self.create_buffer_with_data(label, bytemuck::cast_slice(data), 4, extra_usage)
    }

    fn create_buffer_with_data(
        &self,
        label: &str,
        bytes: &[u8],
        min_size: u64,
        extra_usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        let usage =
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST | extra_usage;
        let size = round_up((bytes.len() as u64).max(min_size), wgpu::COPY_BUFFER_ALIGNMENT);
        self.check_buffer_size(label, size)?;
        self.with_error_scope(
            || format!("create buffer `{label}`"),
            || {
                if bytes.len() as u64 == size {
                    self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(label),
                        contents: bytes,
                        usage,
                    })
                } else {
                    let mut padded = vec![0u8; usize::try_from(size).unwrap_or(usize::MAX)];
                    padded[..bytes.len()].copy_from_slice(bytes);
                    self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(label),
                        contents: &padded,
                        usage,
                    })
                }
            },
        )
    }

    /// A zero-filled storage buffer of `bytes` bytes (rounded up to a multiple of 4, at least 4), usage
    /// `STORAGE | COPY_SRC | COPY_DST`: the usual output buffer.
    ///
    /// # Errors
    /// As [`GpuContext::create_storage_buffer`].
    pub fn create_zeroed_storage_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer, GpuError> {
        let size = round_up(bytes.max(4), wgpu::COPY_BUFFER_ALIGNMENT);
        self.check_buffer_size(label, size)?;
        // wgpu zero-initialises buffers that are not mapped at creation.
        self.with_error_scope(
            || format!("create buffer `{label}`"),
            || {
                self.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            },
        )
    }

    /// A uniform buffer holding `value` (usage `UNIFORM | COPY_DST`), zero-padded to a multiple of 16 bytes.
    ///
    /// The Rust type must match the WGSL struct's *uniform* layout: `vec3<f32>` is 16-byte aligned, struct
    /// members follow WGSL alignment rules; using only 4-byte scalars (and explicit padding) is simplest.
    /// Update it with [`GpuContext::write_buffer`].
    ///
    /// # Errors
    /// [`GpuError::Operation`] if wgpu fails.
    pub fn create_uniform_buffer<T: Pod>(&self, label: &str, value: &T) -> Result<wgpu::Buffer, GpuError> {
        let bytes = bytemuck::bytes_of(value);
        let size = round_up((bytes.len() as u64).max(16), 16);
        let mut padded = vec![0u8; usize::try_from(size).unwrap_or(usize::MAX)];
        padded[..bytes.len()].copy_from_slice(bytes);
        self.with_error_scope(
            || format!("create uniform buffer `{label}`"),
            || {
                self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &padded,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                })
            },
        )
    }

    /// Schedules a write of `data` into `buffer` at `byte_offset` (`queue.write_buffer`); it takes effect
    /// before any command buffer submitted afterwards. `byte_offset` and the data size must be multiples of 4.
    ///
    /// # Errors
    /// [`GpuError::Operation`] on a misaligned or out-of-range write, or a buffer without `COPY_DST`.
    pub fn write_buffer<T: Pod>(&self, buffer: &wgpu::Buffer, byte_offset: u64, data: &[T]) -> Result<(), GpuError> {
        self.with_error_scope(
            || format!("write {} bytes to buffer at offset {byte_offset}", size_of_val(data)),
            || self.queue.write_buffer(buffer, byte_offset, bytemuck::cast_slice(data)),
        )
    }

    /// Reads the first `len` elements of `buffer` back to the CPU. Waits for all work submitted so far that
    /// writes the buffer. The buffer needs `COPY_SRC` usage (all buffers made by this crate have it).
    ///
    /// # Errors
    /// [`GpuError::Readback`] if the buffer is too small, lacks `COPY_SRC`, or mapping fails.
    pub fn read_buffer<T: Pod>(&self, buffer: &wgpu::Buffer, len: usize) -> Result<Vec<T>, GpuError> {
        self.read_buffer_range_chunked(buffer, 0, len, READBACK_CHUNK_BYTES)
    }

    /// Reads `len` elements starting at `byte_offset` (a multiple of 4) of `buffer`.
    ///
    /// # Errors
    /// As [`GpuContext::read_buffer`].
    pub fn read_buffer_range<T: Pod>(
        &self,
        buffer: &wgpu::Buffer,
        byte_offset: u64,
        len: usize,
    ) -> Result<Vec<T>, GpuError> {
        self.read_buffer_range_chunked(buffer, byte_offset, len, READBACK_CHUNK_BYTES)
    }

    /// Reads `len` elements starting at `byte_offset` through a staging buffer of at most
    /// `staging_chunk_bytes` (rounded down to a multiple of 4, at least 4), in as many rounds as needed.
    ///
    /// Each round: `encoder.copy_buffer_to_buffer` into the `MAP_READ | COPY_DST` staging buffer,
    /// `queue.submit`, `staging.map_async(MapMode::Read, ..)`, `device.poll(PollType::Wait { submission_index,
    /// timeout: None })`, wait for the map callback, copy out of `get_mapped_range`, `unmap`.
    ///
    /// # Errors
    /// As [`GpuContext::read_buffer`].
    pub fn read_buffer_range_chunked<T: Pod>(
        &self,
        buffer: &wgpu::Buffer,
        byte_offset: u64,
        len: usize,
        staging_chunk_bytes: u64,
    ) -> Result<Vec<T>, GpuError> {
        let fail = |message: String| GpuError::Readback {
            what: format!("{} bytes at offset {byte_offset} of a {}-byte buffer", size_of::<T>() * len, buffer.size()),
            message,
        };

        let mut out = vec![T::zeroed(); len];
        let out_bytes: &mut [u8] = bytemuck::cast_slice_mut(&mut out);
        let want = out_bytes.len() as u64;
        if want == 0 {
            return Ok(out);
        }
        if !buffer.usage().contains(wgpu::BufferUsages::COPY_SRC) {
            return Err(fail("the buffer lacks COPY_SRC usage".to_owned()));
        }
        if !byte_offset.is_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT) {
            return Err(fail(format!("byte offset {byte_offset} is not a multiple of 4")));
        }
        // Copies move whole 4-byte words; the last word may run past `want` into the buffer's padding.
        let padded = round_up(want, wgpu::COPY_BUFFER_ALIGNMENT);
        if byte_offset.checked_add(padded).is_none_or(|end| end > buffer.size()) {
            return Err(fail(format!(
                "{want} bytes at offset {byte_offset} do not fit in the buffer's {} bytes",
                buffer.size()
            )));
        }

        let chunk = (staging_chunk_bytes / 4 * 4).max(4).min(padded).min(self.limits.max_buffer_size / 4 * 4);
        let staging = self.with_error_scope(
            || "create readback staging buffer".to_owned(),
            || {
                self.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("shatter-gpu readback staging"),
                    size: chunk,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            },
        )?;

        let mut done = 0u64;
        while done < padded {
            let n = chunk.min(padded - done);
            let submission = self.with_error_scope(
                || "copy to readback staging".to_owned(),
                || {
                    let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                        label: Some("shatter-gpu readback"),
                    });
                    encoder.copy_buffer_to_buffer(buffer, byte_offset + done, &staging, 0, n);
                    self.queue.submit([encoder.finish()])
                },
            )?;

            let (sender, receiver) = std::sync::mpsc::channel();
            staging.map_async(wgpu::MapMode::Read, 0..n, move |result| {
                // The receiver lives until this round ends; a failed send cannot happen then.
                let _ = sender.send(result);
            });
            self.device
                .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
                .map_err(|e| fail(format!("waiting for the GPU failed: {e}")))?;
            // The callback has run or is running (possibly on another thread polling the same device).
            receiver
                .recv()
                .map_err(|_| fail("the map callback was dropped".to_owned()))?
                .map_err(|e| fail(error_text(&e)))?;
            {
                let view = staging.get_mapped_range(0..n).map_err(|e| fail(e.to_string()))?;
                let start = usize::try_from(done).unwrap_or(usize::MAX);
                let take = usize::try_from(n.min(want - done)).unwrap_or(usize::MAX);
                out_bytes[start..start + take].copy_from_slice(&view[..take]);
            }
            staging.unmap();
            done += n;
        }
        Ok(out)
    }
}
