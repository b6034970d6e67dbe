//! Per-frame state kept in the scratch folder, so that memory holds a few frames whatever the
//! length of the video: one file per frame with its labels, the source of every pixel and the
//! shading, and one file per cached flow.
//!
//! Formats (little-endian): a 4-byte magic, width and height as `u32`, then
//! - state `frame_NNNNNN.state` (magic `IVS1`): labels `u32 × n`, sources `u8 × n`, shading
//!   `f32 × n` (9 bytes a pixel);
//! - flow `fwd_NNNNNN.flow` (frame t to t + 1) and `bwd_NNNNNN.flow` (frame t + 1 to t), magic
//!   `IVF1`: `u` then `v`, `f32 × n` each;
//! - step 8's single-image shadings (module `fusion`) `view_NNNNNN.shading`, magic `IVV1`, and
//!   `clustering_NNNNNN.shading`, magic `IVC1`: `f32 × n`.
//!
//! The reflectance is not stored: it is `input / shading` of the re-read input frame.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::video::flow::Flow;

/// Where a pixel's final decomposition came from (each pixel gets exactly one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum PixelSource {
    /// Not assigned yet.
    Unassigned = 0,
    /// MAP propagation of a cluster from a neighbouring frame (§3.5).
    Propagation = 1,
    /// The first frame's decomposition, or completion at a stopping frame (§3.6, eqs. 3.8–3.10).
    Completion = 2,
    /// The final Laplace fill of the shading (eq. 3.11).
    Residual = 3,
}

impl PixelSource {
    fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::Unassigned,
            1 => Self::Propagation,
            2 => Self::Completion,
            3 => Self::Residual,
            _ => return None,
        })
    }
}

/// One frame's decomposition so far.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FrameState {
    pub width: u32,
    pub height: u32,
    /// Cluster per pixel, [`Labels::NONE`] where unassigned (or where the residual fill found
    /// no labelled pixel).
    pub labels: Vec<u32>,
    pub source: Vec<PixelSource>,
    /// Grey shading where assigned (0 elsewhere).
    pub shading: Vec<f32>,
}

impl FrameState {
    /// A frame with nothing assigned.
    pub fn empty(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            labels: vec![Labels::NONE; n],
            source: vec![PixelSource::Unassigned; n],
            shading: vec![0.0; n],
        }
    }

    /// A black frame before the first lit one (module `first`): every pixel decided, with
    /// no cluster and no light (shading 0, reflectance 0), counted as completion.
    pub fn black(width: u32, height: u32) -> Self {
        let mut state = Self::empty(width, height);
        state.source.fill(PixelSource::Completion);
        state
    }

    pub fn len(&self) -> usize {
        self.labels.len()
    }

    pub fn unassigned(&self) -> usize {
        self.source
            .iter()
            .filter(|&&s| s == PixelSource::Unassigned)
            .count()
    }

    /// `true` where assigned (the input of the stopping condition).
    pub fn assigned_mask(&self) -> Mask {
        let data = self
            .source
            .iter()
            .map(|&s| s != PixelSource::Unassigned)
            .collect();
        Mask::from_vec(self.width, self.height, data).expect("one source per pixel")
    }

    /// The labels as [`Labels`] with `count` clusters.
    pub fn labels(&self, count: usize) -> Labels {
        Labels {
            width: self.width,
            height: self.height,
            data: self.labels.clone(),
            count,
        }
    }

    /// `input / shading` per channel where assigned and lit, 0 elsewhere.
    pub fn reflectance(&self, input: &Image) -> Image {
        let mut r = Image::new(self.width, self.height, 3);
        for i in 0..self.len() {
            if self.source[i] != PixelSource::Unassigned && self.shading[i] > 0.0 {
                let s = self.shading[i];
                r.px_mut(i).copy_from_slice(&input.rgb(i).map(|v| v / s));
            }
        }
        r
    }
}

/// Step 8's single-image decompositions of a frame, each cached in a file of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Member {
    /// The light-field method on the frame as one view ([`super::fusion::single_view_shading`]).
    View,
    /// The clustering method of thesis ch. 2 ([`super::fusion::clustering_shading`]).
    Clustering,
}

impl Member {
    fn prefix(self) -> &'static str {
        match self {
            Self::View => "view",
            Self::Clustering => "clustering",
        }
    }

    fn magic(self) -> &'static [u8; 4] {
        match self {
            Self::View => b"IVV1",
            Self::Clustering => b"IVC1",
        }
    }
}

/// The scratch folder's files.
#[derive(Clone, Debug)]
pub(crate) struct Scratch {
    dir: PathBuf,
}

impl Scratch {
    /// Uses (and creates if needed) `dir`.
    pub fn new(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        Ok(Self {
            dir: dir.to_path_buf(),
        })
    }

    pub fn state_path(&self, t: usize) -> PathBuf {
        self.dir.join(format!("frame_{t:06}.state"))
    }

    fn flow_path(&self, t: usize, forward: bool) -> PathBuf {
        let kind = if forward { "fwd" } else { "bwd" };
        self.dir.join(format!("{kind}_{t:06}.flow"))
    }

    fn member_path(&self, member: Member, t: usize) -> PathBuf {
        self.dir.join(format!("{}_{t:06}.shading", member.prefix()))
    }

    /// Caches frame t's shading by one of step 8's single-image decompositions.
    pub fn save_member_shading(
        &self,
        member: Member,
        t: usize,
        dims: (u32, u32),
        shading: &[f32],
    ) -> Result<()> {
        let mut buf = header(member.magic(), dims.0, dims.1, 4 * shading.len());
        for &x in shading {
            buf.extend_from_slice(&x.to_le_bytes());
        }
        write(&self.member_path(member, t), &buf)
    }

    /// Whether frame t's shading by `member` is cached.
    pub fn has_member_shading(&self, member: Member, t: usize) -> bool {
        self.member_path(member, t).is_file()
    }

    /// Frame t's cached shading by `member`, if computed.
    pub fn load_member_shading(
        &self,
        member: Member,
        t: usize,
        dims: (u32, u32),
    ) -> Result<Option<Vec<f32>>> {
        let path = self.member_path(member, t);
        if !path.is_file() {
            return Ok(None);
        }
        let bytes = read(&path)?;
        let n = dims.0 as usize * dims.1 as usize;
        Ok(Some(f32s(check_header(
            &path,
            &bytes,
            member.magic(),
            dims,
            4 * n,
        )?)))
    }

    pub fn has_state(&self, t: usize) -> bool {
        self.state_path(t).is_file()
    }

    pub fn save_state(&self, t: usize, s: &FrameState) -> Result<()> {
        let mut buf = header(b"IVS1", s.width, s.height, 9 * s.len());
        for &l in &s.labels {
            buf.extend_from_slice(&l.to_le_bytes());
        }
        buf.extend(s.source.iter().map(|&v| v as u8));
        for &v in &s.shading {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        write(&self.state_path(t), &buf)
    }

    /// The frame's state, or an empty one when it was never saved.
    pub fn load_state(&self, t: usize, dims: (u32, u32)) -> Result<FrameState> {
        let path = self.state_path(t);
        if !path.is_file() {
            return Ok(FrameState::empty(dims.0, dims.1));
        }
        let bytes = read(&path)?;
        let n = dims.0 as usize * dims.1 as usize;
        let body = check_header(&path, &bytes, b"IVS1", dims, 9 * n)?;
        let (labels, rest) = body.split_at(4 * n);
        let (source, shading) = rest.split_at(n);
        let source = source
            .iter()
            .map(|&v| PixelSource::from_u8(v).ok_or_else(|| malformed(&path, "pixel source")))
            .collect::<Result<_>>()?;
        Ok(FrameState {
            width: dims.0,
            height: dims.1,
            labels: u32s(labels),
            source,
            shading: f32s(shading),
        })
    }

    /// Whether the flow from frame t to t + 1 (`forward`) or back is cached.
    pub fn has_flow(&self, t: usize, forward: bool) -> bool {
        self.flow_path(t, forward).is_file()
    }

    /// The cached flow from frame t to t + 1 (`forward`) or from t + 1 to t, if computed.
    pub fn load_flow(&self, t: usize, forward: bool, dims: (u32, u32)) -> Result<Option<Flow>> {
        let path = self.flow_path(t, forward);
        if !path.is_file() {
            return Ok(None);
        }
        let bytes = read(&path)?;
        let n = dims.0 as usize * dims.1 as usize;
        let body = check_header(&path, &bytes, b"IVF1", dims, 8 * n)?;
        let (u, v) = body.split_at(4 * n);
        Flow::from_vecs(dims.0, dims.1, f32s(u), f32s(v)).map(Some)
    }

    pub fn save_flow(&self, t: usize, forward: bool, f: &Flow) -> Result<()> {
        let (w, h) = f.dims();
        let mut buf = header(b"IVF1", w, h, 4 * (f.u().len() + f.v().len()));
        for &x in f.u().iter().chain(f.v()) {
            buf.extend_from_slice(&x.to_le_bytes());
        }
        write(&self.flow_path(t, forward), &buf)
    }
}

fn header(magic: &[u8; 4], w: u32, h: u32, body: usize) -> Vec<u8> {
    let mut buf = Vec::with_capacity(12 + body);
    buf.extend_from_slice(magic);
    buf.extend_from_slice(&w.to_le_bytes());
    buf.extend_from_slice(&h.to_le_bytes());
    buf
}

fn check_header<'a>(
    path: &Path,
    bytes: &'a [u8],
    magic: &[u8; 4],
    dims: (u32, u32),
    body: usize,
) -> Result<&'a [u8]> {
    if bytes.len() != 12 + body || &bytes[..4] != magic {
        return Err(malformed(path, "wrong magic or length"));
    }
    let w = u32::from_le_bytes(bytes[4..8].try_into().expect("4 bytes"));
    let h = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if (w, h) != dims {
        return Err(malformed(path, "another frame size"));
    }
    Ok(&bytes[12..])
}

fn malformed(path: &Path, what: &str) -> Error {
    Error::Format {
        path: path.to_path_buf(),
        message: format!("scratch file of the video method: {what}"),
    }
}

fn u32s(b: &[u8]) -> Vec<u32> {
    b.chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect()
}

fn f32s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect()
}

fn write(path: &Path, buf: &[u8]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut f = std::fs::File::create(path).map_err(io)?;
    f.write_all(buf).map_err(io)
}

fn read(path: &Path) -> Result<Vec<u8>> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut buf = Vec::new();
    std::fs::File::open(path)
        .map_err(io)?
        .read_to_end(&mut buf)
        .map_err(io)?;
    Ok(buf)
}
