//! Splitting arrays larger than one storage binding into aligned chunks.

use std::num::NonZeroU64;
use std::ops::Range;

use crate::{GpuContext, GpuError};

/// One piece of an array that is too large for a single storage-buffer binding.
///
/// Chunks come from [`split_for_binding`]; together they cover elements `0..len` exactly once, in order.
/// Every chunk starts at a byte offset that is a multiple of the offset alignment (so it can be bound at that
/// offset of one big buffer), and every chunk's [`binding_size`](BindingChunk::binding_size) is at most the
/// binding limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BindingChunk {
    /// Position of the chunk in the list, from 0.
    pub index: usize,
    /// First element of the chunk.
    pub first: usize,
    /// Number of elements in the chunk (> 0).
    pub len: usize,
    /// Byte offset of the chunk's first element: `first * size_of::<T>()`.
    pub byte_offset: u64,
    /// Bytes of element data in the chunk: `len * size_of::<T>()`.
    pub byte_len: u64,
}

impl BindingChunk {
    /// The element range `first..first + len`.
    #[must_use]
    pub fn range(&self) -> Range<usize> {
        self.first..self.first + self.len
    }

    /// The chunk's elements of `data` (the slice the chunks were computed for).
    ///
    /// # Panics
    /// If `data` is shorter than the chunk's end.
    #[must_use]
    pub fn slice_of<'a, T>(&self, data: &'a [T]) -> &'a [T] {
        &data[self.range()]
    }

    /// The size to bind: [`byte_len`](BindingChunk::byte_len) rounded up to a multiple of 4 (storage
    /// bindings are whole 4-byte words; buffers from this crate are padded accordingly).
    #[must_use]
    pub fn binding_size(&self) -> u64 {
        self.byte_len.div_ceil(4) * 4
    }

    /// A binding of this chunk of `buffer` (which holds the whole array from offset 0), for a bind group entry.
    ///
    /// # Panics
    /// Never for chunks from [`split_for_binding`] (they are never empty).
    #[must_use]
    pub fn binding<'a>(&self, buffer: &'a wgpu::Buffer) -> wgpu::BindingResource<'a> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer,
            offset: self.byte_offset,
            size: NonZeroU64::new(self.binding_size()),
        })
    }
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

fn lcm(a: u64, b: u64) -> Option<u64> {
    (a / gcd(a, b)).checked_mul(b)
}

/// Splits `len` elements of `elem_bytes` bytes each into chunks for separate storage bindings.
///
/// Each chunk is as large as possible subject to: its bytes are at most `max_binding_bytes`, and every chunk
/// but the last holds a whole multiple of `lcm(elem_bytes, offset_alignment, 4)` bytes, so each chunk starts
/// at a multiple of `offset_alignment` (use the device's `min_storage_buffer_offset_alignment`) and on an
/// element boundary. Only the last chunk may be shorter. `len == 0` gives no chunks.
///
/// # Errors
/// [`GpuError::Split`] if `elem_bytes` or `offset_alignment` is 0, or if not even one aligned step fits in
/// `max_binding_bytes`.
pub fn split_for_binding(
    len: usize,
    elem_bytes: u64,
    max_binding_bytes: u64,
    offset_alignment: u64,
) -> Result<Vec<BindingChunk>, GpuError> {
    if elem_bytes == 0 || offset_alignment == 0 {
        return Err(GpuError::Split {
            message: format!("element size ({elem_bytes}) and offset alignment ({offset_alignment}) must be non-zero"),
        });
    }
    let step = lcm(elem_bytes, offset_alignment).and_then(|s| lcm(s, 4)).ok_or_else(|| GpuError::Split {
        message: format!("lcm of element size {elem_bytes} and alignment {offset_alignment} overflows"),
    })?;
    if step > max_binding_bytes {
        return Err(GpuError::Split {
            message: format!(
                "one aligned step of {step} bytes (lcm of element size {elem_bytes}, offset alignment \
                 {offset_alignment} and 4) exceeds the binding limit of {max_binding_bytes} bytes"
            ),
        });
    }
    let chunk_bytes = max_binding_bytes / step * step;
    let chunk_elems = usize::try_from(chunk_bytes / elem_bytes).unwrap_or(usize::MAX);

    let mut chunks = Vec::with_capacity(len.div_ceil(chunk_elems));
    let mut first = 0usize;
    while first < len {
        let n = chunk_elems.min(len - first);
        chunks.push(BindingChunk {
            index: chunks.len(),
            first,
            len: n,
            byte_offset: first as u64 * elem_bytes,
            byte_len: n as u64 * elem_bytes,
        });
        first += n;
    }
    Ok(chunks)
}

/// [`split_for_binding`] for a slice: each chunk with its sub-slice (e.g. to upload into one buffer per chunk
/// when even `max_buffer_size` is too small for the whole array).
///
/// # Errors
/// As [`split_for_binding`].
pub fn split_slice_for_binding<T>(
    data: &[T],
    max_binding_bytes: u64,
    offset_alignment: u64,
) -> Result<Vec<(BindingChunk, &[T])>, GpuError> {
    let chunks = split_for_binding(data.len(), size_of::<T>() as u64, max_binding_bytes, offset_alignment)?;
    Ok(chunks.into_iter().map(|c| (c, c.slice_of(data))).collect())
}

impl GpuContext {
    /// [`split_for_binding`] with this device's limits: [`GpuContext::max_storage_binding_bytes`] and
    /// `min_storage_buffer_offset_alignment`. An array that fits in one binding gives one chunk.
    ///
    /// # Errors
    /// As [`split_for_binding`] (only for zero-sized or absurdly large `T`).
    pub fn binding_chunks<T>(&self, len: usize) -> Result<Vec<BindingChunk>, GpuError> {
        split_for_binding(
            len,
            size_of::<T>() as u64,
            self.max_storage_binding_bytes(),
            u64::from(self.limits.min_storage_buffer_offset_alignment),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks every documented property of a split.
    fn check(len: usize, elem: u64, max: u64, align: u64) {
        let chunks = split_for_binding(len, elem, max, align).expect("valid split parameters");
        let mut next = 0usize;
        for (i, c) in chunks.iter().enumerate() {
            assert_eq!(c.index, i);
            assert_eq!(c.first, next, "chunks must be contiguous");
            assert!(c.len > 0, "no empty chunks");
            assert_eq!(c.byte_offset, c.first as u64 * elem);
            assert_eq!(c.byte_len, c.len as u64 * elem);
            assert_eq!(c.byte_offset % align, 0, "offset {} not aligned to {align}", c.byte_offset);
            assert!(c.binding_size() <= max, "chunk {i} binding {} > max {max}", c.binding_size());
            assert_eq!(c.binding_size() % 4, 0);
            assert!(c.binding_size() >= c.byte_len);
            if i + 1 < chunks.len() {
                assert_eq!(c.byte_len % 4, 0);
            }
            next += c.len;
        }
        assert_eq!(next, len, "chunks must cover the whole range");
        // Maximal: all chunks but the last have the same size, and one more aligned step would not fit.
        if let Some((last, rest)) = chunks.split_last() {
            let step = lcm(elem, align).and_then(|s| lcm(s, 4)).expect("small numbers");
            for c in rest {
                assert_eq!(c.len, chunks[0].len);
                assert_eq!(c.byte_len % step, 0);
                assert!(c.byte_len + step > max, "chunk of {} B could grow by a step of {step} B", c.byte_len);
            }
            assert!(last.len <= chunks[0].len);
        }
    }

    #[test]
    fn covers_exactly_and_respects_alignment() {
        for &len in &[0usize, 1, 2, 3, 7, 63, 64, 65, 1000, 4096, 100_003] {
            for &elem in &[1u64, 2, 4, 8, 12, 16, 20, 48] {
                for &align in &[4u64, 16, 32, 64, 256] {
                    for &max in &[256u64, 1000, 1024, 4096, 65_536, 1 << 27] {
                        if split_for_binding(len, elem, max, align).is_ok() {
                            check(len, elem, max, align);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn fake_small_limit_example() {
        // 1000 vec3<f32>-sized (12 B) elements, 1000 B limit, 256 B alignment: steps of lcm(12, 256) = 768 B.
        let chunks = split_for_binding(1000, 12, 1000, 256).expect("fits");
        assert_eq!(chunks[0].len, 64);
        assert_eq!(chunks[0].byte_len, 768);
        assert_eq!(chunks[1].byte_offset, 768);
        assert_eq!(chunks.len(), 1000usize.div_ceil(64));
        assert_eq!(chunks.last().map(|c| c.len), Some(1000 - 15 * 64));
    }

    #[test]
    fn fits_in_one_chunk() {
        let chunks = split_for_binding(10, 4, 1 << 20, 256).expect("fits");
        assert_eq!(chunks, vec![BindingChunk { index: 0, first: 0, len: 10, byte_offset: 0, byte_len: 40 }]);
    }

    #[test]
    fn odd_sized_elements_get_padded_bindings() {
        // u16 elements: the last chunk of 3 elements is 6 bytes, bound as 8.
        let chunks = split_for_binding(35, 2, 64, 32).expect("fits");
        assert_eq!(chunks.len(), 2);
        assert_eq!(chunks[0].len, 32);
        assert_eq!(chunks[1].byte_len, 6);
        assert_eq!(chunks[1].binding_size(), 8);
    }

    #[test]
    fn slices_follow_chunks() {
        let data: Vec<u32> = (0..1000).collect();
        let parts = split_slice_for_binding(&data, 512, 64).expect("fits");
        let joined: Vec<u32> = parts.iter().flat_map(|(_, s)| s.iter().copied()).collect();
        assert_eq!(joined, data);
        assert!(parts.iter().all(|(c, s)| s.len() == c.len && size_of_val(*s) as u64 <= 512));
    }

    #[test]
    fn impossible_parameters_are_errors() {
        assert!(matches!(split_for_binding(10, 0, 1024, 256), Err(GpuError::Split { .. })));
        assert!(matches!(split_for_binding(10, 4, 1024, 0), Err(GpuError::Split { .. })));
        // lcm(12, 256) = 768 > 512.
        let err = split_for_binding(10, 12, 512, 256).expect_err("step too large");
        assert!(err.to_string().contains("768"), "{err}");
    }
}
