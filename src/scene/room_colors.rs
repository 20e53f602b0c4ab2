//! The colour of each MINOS room class, shared by every picture that shows rooms (grid
//! previews, room-class images, recordings), so a class has one colour everywhere.

/// Colour of each MINOS room class (0 other … 8 outdoor).
pub const ROOM_CLASS_COLORS: [[u8; 3]; 9] = [
    [190, 190, 170],
    [150, 160, 235],
    [140, 210, 140],
    [120, 210, 230],
    [240, 200, 120],
    [235, 230, 120],
    [220, 150, 220],
    [235, 190, 160],
    [160, 230, 170],
];

/// The colour of MINOS room class `class`; classes past the last (8, outdoor) take its colour.
pub fn room_class_color(class: u8) -> [u8; 3] {
    ROOM_CLASS_COLORS[usize::from(class.min(8))]
}
