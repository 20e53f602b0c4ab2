//! Images a renderer derived itself beside a frame's triangle ids and depth: which ones a
//! caller asks for ([`Channels`]) and the images ([`Derived`]). The GPU ray tracer derives
//! them in a second compute pass with the formulas of [`super::frame`] (so a batch reads back
//! finished images instead of ids that host cores turn into images); [`super::Frame`]'s
//! methods return a derived image where the frame carries one and derive it on the CPU
//! otherwise, so callers never know which side made it.

use super::image::Modality;
use crate::scene::Taxonomy;

/// A set of images to derive, one bit per [`Channel`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Channels(u32);

/// One image a renderer can derive from a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Shaded, textured RGB ([`super::Frame::color`]).
    Color,
    /// Linear depth in metres ([`super::Frame::linear_depth`]).
    Depth,
    /// World normals ([`super::Frame::normals`]).
    Normal,
    /// Semantic class in a taxonomy ([`super::Frame::semantic`]).
    Semantic(Taxonomy),
    /// Object instance ([`super::Frame::instance`]).
    Instance,
    /// Room ([`super::Frame::room`]).
    Room,
    /// MINOS room class ([`super::Frame::room_class`]).
    RoomClass,
}

impl Channel {
    /// Every channel, in the order the GPU lays them out.
    pub const ALL: [Channel; 9] = [
        Channel::Color,
        Channel::Depth,
        Channel::Normal,
        Channel::Semantic(Taxonomy::Nyu40),
        Channel::Semantic(Taxonomy::Mpcat40),
        Channel::Semantic(Taxonomy::Coarse),
        Channel::Instance,
        Channel::Room,
        Channel::RoomClass,
    ];

    /// The channel's place in [`Channel::ALL`] (its bit in [`Channels`]).
    pub fn index(self) -> usize {
        match self {
            Channel::Color => 0,
            Channel::Depth => 1,
            Channel::Normal => 2,
            Channel::Semantic(Taxonomy::Nyu40) => 3,
            Channel::Semantic(Taxonomy::Mpcat40) => 4,
            Channel::Semantic(Taxonomy::Coarse) => 5,
            Channel::Instance => 6,
            Channel::Room => 7,
            Channel::RoomClass => 8,
        }
    }

    /// 32-bit words per pixel the GPU writes for it.
    pub fn words(self) -> usize {
        match self {
            Channel::Normal => 3,
            _ => 1,
        }
    }
}

impl Channels {
    /// Nothing derived: the renderer gives triangle ids and depth only.
    pub const NONE: Channels = Channels(0);

    /// Every channel.
    pub fn all() -> Channels {
        Channel::ALL.iter().fold(Channels::NONE, |c, &k| c.with(k))
    }

    /// This set plus `channel`.
    pub fn with(self, channel: Channel) -> Channels {
        Channels(self.0 | 1 << channel.index())
    }

    /// Both sets.
    pub fn union(self, other: Channels) -> Channels {
        Channels(self.0 | other.0)
    }

    /// Whether `channel` is in the set.
    pub fn contains(self, channel: Channel) -> bool {
        self.0 & (1 << channel.index()) != 0
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The channels of the set, in [`Channel::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Channel> {
        Channel::ALL.into_iter().filter(move |&c| self.contains(c))
    }

    /// The channels a camera sensor of `modality` reads (grey is made from colour; the
    /// semantic modality's taxonomy is `taxonomy`).
    pub fn for_modality(modality: Modality, taxonomy: Taxonomy) -> Channels {
        let channel = match modality {
            Modality::Color | Modality::Gray => Channel::Color,
            Modality::Depth => Channel::Depth,
            Modality::Normal => Channel::Normal,
            Modality::Semantic => Channel::Semantic(taxonomy),
            Modality::Instance => Channel::Instance,
            Modality::Room => Channel::Room,
            Modality::RoomClass => Channel::RoomClass,
        };
        Channels::NONE.with(channel)
    }
}

/// Images a renderer derived for a frame; a `None` image is derived on the CPU when asked.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Derived {
    /// Shaded RGB.
    pub color: Option<Vec<[u8; 3]>>,
    /// Linear depth (m, 0 where nothing is hit).
    pub linear_depth: Option<Vec<f32>>,
    /// World normals.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Semantic classes by taxonomy (NYU-40, mpcat40, coarse).
    pub semantic: [Option<Vec<u16>>; 3],
    /// Object instances.
    pub instance: Option<Vec<u32>>,
    /// Rooms.
    pub room: Option<Vec<u32>>,
    /// MINOS room classes.
    pub room_class: Option<Vec<u8>>,
}

/// The place of `taxonomy` in [`Derived::semantic`].
pub fn taxonomy_slot(taxonomy: Taxonomy) -> usize {
    match taxonomy {
        Taxonomy::Nyu40 => 0,
        Taxonomy::Mpcat40 => 1,
        Taxonomy::Coarse => 2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_are_distinct_bits_in_layout_order() {
        for (i, c) in Channel::ALL.iter().enumerate() {
            assert_eq!(c.index(), i);
        }
        let all = Channels::all();
        assert_eq!(all.iter().count(), Channel::ALL.len());
        let some = Channels::NONE
            .with(Channel::Room)
            .union(Channels::for_modality(Modality::Gray, Taxonomy::Nyu40));
        assert_eq!(
            some.iter().collect::<Vec<_>>(),
            vec![Channel::Color, Channel::Room]
        );
        assert!(!some.contains(Channel::Depth));
        assert!(Channels::NONE.is_empty() && !some.is_empty());
        assert!(Channels::for_modality(Modality::Semantic, Taxonomy::Coarse)
            .contains(Channel::Semantic(Taxonomy::Coarse)));
    }
}
