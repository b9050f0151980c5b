//! What a case records: images of named channels, one pixel per ray (hit records) or per
//! pixel (rendered images). Integer channels hold `u32` values; float channels hold `f32`
//! values, kept as their bit patterns so NaN payloads and signed zeros survive untouched.

/// The type of a channel, as stored in EXR.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ChannelKind {
    /// `u32` values (EXR `UINT`).
    Uint,
    /// `f32` values (EXR `FLOAT`).
    Float,
}

impl ChannelKind {
    /// `UINT` or `FLOAT`, as EXR and OpenImageIO name them.
    pub fn exr_name(self) -> &'static str {
        match self {
            ChannelKind::Uint => "UINT",
            ChannelKind::Float => "FLOAT",
        }
    }
}

/// One channel of an image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Channel {
    /// Its name (`t`, `prim`, `R`).
    pub name: String,
    /// Its type.
    pub kind: ChannelKind,
    /// One value per pixel, row by row: `u32` values, or `f32` bit patterns.
    pub values: Vec<u32>,
}

impl Channel {
    /// The value of pixel `i` as `f64` (floats converted from their bits).
    pub fn value_f64(&self, i: usize) -> f64 {
        match self.kind {
            ChannelKind::Uint => self.values[i] as f64,
            ChannelKind::Float => f32::from_bits(self.values[i]) as f64,
        }
    }
}

/// A width × height image of named channels.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordImage {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The channels, in the order the case lists them.
    pub channels: Vec<Channel>,
}

impl RecordImage {
    /// An image with these channels, every value zero.
    pub fn zeroed(width: usize, height: usize, channels: &[(String, ChannelKind)]) -> Self {
        RecordImage {
            width,
            height,
            channels: channels
                .iter()
                .map(|(name, kind)| Channel {
                    name: name.clone(),
                    kind: *kind,
                    values: vec![0; width * height],
                })
                .collect(),
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }

    /// The channel named `name`.
    pub fn channel(&self, name: &str) -> Option<&Channel> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// Whether two images have the same size and the same channel names and types (in any
    /// order), as idiff requires before it compares values.
    pub fn same_layout(&self, other: &RecordImage) -> bool {
        self.width == other.width
            && self.height == other.height
            && self.channels.len() == other.channels.len()
            && self
                .channels
                .iter()
                .all(|c| other.channel(&c.name).is_some_and(|o| o.kind == c.kind))
    }

    /// A description of the layout for messages: `64×32 [hit:UINT, t:FLOAT]`.
    pub fn layout_text(&self) -> String {
        let names: Vec<String> = self
            .channels
            .iter()
            .map(|c| format!("{}:{}", c.name, c.kind.exr_name()))
            .collect();
        format!("{}×{} [{}]", self.width, self.height, names.join(", "))
    }

    /// The (x, y) position of pixel `i`.
    pub fn position(&self, i: usize) -> (usize, usize) {
        (i % self.width.max(1), i / self.width.max(1))
    }
}
