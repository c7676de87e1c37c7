//! Reading buffers and textures back to the CPU: a copy into a `MAP_READ` staging buffer,
//! mapped after the device has finished. Inputs wgpu would reject (ranges outside the
//! buffer or unaligned, missing `COPY_SRC`, formats without a plain texel layout) are
//! refused with a [`GpuError`] before anything is recorded, and any validation error wgpu
//! still raises is returned instead of panicking.

use std::ops::{Bound, RangeBounds};

use crate::GpuError;

/// Runs `record` on a new encoder, submits it and waits, turning wgpu validation errors into
/// [`GpuError::Validation`].
fn submit_checked(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    what: &str,
    record: impl FnOnce(&mut wgpu::CommandEncoder),
) -> Result<(), GpuError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(what) });
    record(&mut encoder);
    queue.submit([encoder.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Validation { what: what.to_owned(), message: e.to_string() });
    }
    Ok(())
}

/// Maps `staging` (all of it) for reading after the device is idle and returns its bytes.
fn map_staging(device: &wgpu::Device, staging: &wgpu::Buffer, what: &str) -> Result<Vec<u8>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        // The receiver waits below; if it is gone there is nobody to tell.
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|source| GpuError::Poll { what: format!("reading back {what}"), source })?;
    let mapped = rx.recv().map_err(|_| GpuError::Readback {
        what: what.to_owned(),
        message: "the map callback was dropped without an answer".into(),
    })?;
    mapped.map_err(|source| GpuError::Map { what: what.to_owned(), source })?;
    let bytes = staging
        .slice(..)
        .get_mapped_range()
        .map_err(|e| GpuError::Readback { what: what.to_owned(), message: e.to_string() })?
        .to_vec();
    staging.unmap();
    Ok(bytes)
}

/// The bytes `range` of `buffer` (which needs `COPY_SRC` usage), after every command
/// submitted before. The range's start and length must be multiples of 4
/// ([`wgpu::COPY_BUFFER_ALIGNMENT`]) and lie within the buffer.
pub fn read_buffer(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    range: impl RangeBounds<u64>,
) -> Result<Vec<u8>, GpuError> {
    let size = buffer.size();
    let what = format!("a {size}-byte buffer");
    let start = match range.start_bound() {
        Bound::Included(&s) => Some(s),
        Bound::Excluded(&s) => s.checked_add(1),
        Bound::Unbounded => Some(0),
    };
    let end = match range.end_bound() {
        Bound::Included(&e) => e.checked_add(1),
        Bound::Excluded(&e) => Some(e),
        Bound::Unbounded => Some(size),
    };
    let bad = |message: String| GpuError::Readback { what: what.clone(), message };
    let (Some(start), Some(end)) = (start, end) else {
        return Err(bad("the range overflows u64".into()));
    };
    if start > end || end > size {
        return Err(bad(format!("range {start}..{end} is not within the buffer's {size} bytes")));
    }
    let align = wgpu::COPY_BUFFER_ALIGNMENT;
    if start % align != 0 || (end - start) % align != 0 {
        return Err(bad(format!("range {start}..{end}: start and length must be multiples of {align} bytes")));
    }
    if !buffer.usage().contains(wgpu::BufferUsages::COPY_SRC) {
        return Err(bad(format!("the buffer's usage {:?} lacks COPY_SRC", buffer.usage())));
    }
    if start == end {
        return Ok(Vec::new());
    }
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read_buffer staging"),
        size: end - start,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    submit_checked(device, queue, "read_buffer copy", |encoder| {
        encoder.copy_buffer_to_buffer(buffer, start, &staging, 0, end - start);
    })?;
    map_staging(device, &staging, &what)
}

/// [`read_buffer`] as values of `T` (the range's length must be a multiple of `T`'s size).
pub fn read_buffer_as<T: bytemuck::Pod>(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    range: impl RangeBounds<u64>,
) -> Result<Vec<T>, GpuError> {
    let bytes = read_buffer(device, queue, buffer, range)?;
    let t = size_of::<T>();
    if t == 0 || bytes.len() % t != 0 {
        return Err(GpuError::Readback {
            what: "a buffer".into(),
            message: format!("{} bytes are not a whole number of {}-byte values", bytes.len(), t),
        });
    }
    // Copied into a vector of `T` so the values are aligned whatever the bytes' alignment.
    let mut values = vec![T::zeroed(); bytes.len() / t];
    bytemuck::cast_slice_mut::<T, u8>(&mut values).copy_from_slice(&bytes);
    Ok(values)
}

/// Mip level 0 of `texture` (every array layer or depth slice, one after the other) as
/// tightly packed rows of texels, after every command submitted before. Any format with
/// 1x1 texel blocks and a single aspect (colour formats, `Depth32Float`, `Stencil8`, ...);
/// the texture needs `COPY_SRC` usage and one sample per texel. Rows are copied with the
/// 256-byte row alignment copies need ([`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`]) and the padding
/// is dropped.
pub fn read_texture(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
    let format = texture.format();
    let what =
        format!("a {}x{}x{} {format:?} texture", texture.width(), texture.height(), texture.depth_or_array_layers());
    let bad = |message: String| GpuError::Readback { what: what.clone(), message };
    if !texture.usage().contains(wgpu::TextureUsages::COPY_SRC) {
        return Err(bad(format!("its usage {:?} lacks COPY_SRC", texture.usage())));
    }
    if texture.sample_count() != 1 {
        return Err(bad(format!("it has {} samples per texel (resolve it first)", texture.sample_count())));
    }
    if format.block_dimensions() != (1, 1) {
        return Err(bad(format!("its format has {:?} texel blocks", format.block_dimensions())));
    }
    let Some(texel) = format.block_copy_size(None) else {
        return Err(bad("its format has several aspects or planes: no single texel layout".into()));
    };
    let (w, h, layers) = (texture.width(), texture.height(), texture.depth_or_array_layers());
    let row = u64::from(texel) * u64::from(w);
    let align = u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let padded = row.div_ceil(align) * align;
    let size = padded * u64::from(h) * u64::from(layers);
    let max = device.limits().max_buffer_size;
    let Ok(padded_u32) = u32::try_from(padded) else {
        return Err(bad(format!("a row of {padded} bytes exceeds a copy's limit")));
    };
    if size > max {
        return Err(bad(format!("its {size} bytes with padded rows exceed the device's buffer limit of {max}")));
    }
    if size == 0 {
        return Ok(Vec::new());
    }
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read_texture staging"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    submit_checked(device, queue, "read_texture copy", |encoder| {
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_u32),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: layers },
        );
    })?;
    let data = map_staging(device, &staging, &what)?;
    let (row, padded) = (row as usize, padded as usize);
    let mut out = Vec::with_capacity(row * h as usize * layers as usize);
    for line in data.chunks_exact(padded) {
        out.extend_from_slice(&line[..row]);
    }
    Ok(out)
}
