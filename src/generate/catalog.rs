//! The model library of generated houses: furniture, doors, arches, windows and stairs built
//! from boxes, each with SUNCG-style categories (fine, coarse, NYU-40).
//!
//! Models are defined in their own frame: footprint centred on the origin, resting on y = 0,
//! front facing +Z (SUNCG's `front`). The library is fixed (no randomness at run time), so
//! every generated dataset shares the same `object/` folder and category table.

use std::collections::HashMap;
use std::sync::OnceLock;

use crate::seed::{derive_seed, Rng};

/// One box of a model, in model space.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Minimum corner.
    pub min: [f64; 3],
    /// Maximum corner.
    pub max: [f64; 3],
    /// Material slot.
    pub material: usize,
}

/// A named material of a model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelMaterial {
    /// Material name (unique within the model).
    pub name: String,
    /// sRGB colour in `[0, 1]`.
    pub rgb: [f64; 3],
    /// Opacity (1 = opaque).
    pub alpha: f64,
}

/// A model of the library.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelSpec {
    /// SUNCG-style model id (`g_double_bed_1`).
    pub id: String,
    /// Fine-grained category.
    pub fine: &'static str,
    /// Coarse category.
    pub coarse: &'static str,
    /// NYU-40 class.
    pub nyu40: &'static str,
    /// Material slots.
    pub materials: Vec<ModelMaterial>,
    /// The boxes it is made of.
    pub parts: Vec<Part>,
    /// Width (x), height (y) and depth (z) of its box.
    pub size: [f64; 3],
    /// Height of a top surface that small objects may stand on.
    pub top: Option<f64>,
}

impl ModelSpec {
    fn new(id: String, fine: &'static str, coarse: &'static str, nyu40: &'static str) -> Self {
        ModelSpec {
            id,
            fine,
            coarse,
            nyu40,
            materials: Vec::new(),
            parts: Vec::new(),
            size: [0.0; 3],
            top: None,
        }
    }

    fn mat(mut self, name: &str, rgb: [f64; 3]) -> Self {
        self.materials.push(ModelMaterial {
            name: name.to_string(),
            rgb,
            alpha: 1.0,
        });
        self
    }

    fn glass(mut self, name: &str, rgb: [f64; 3], alpha: f64) -> Self {
        self.materials.push(ModelMaterial {
            name: name.to_string(),
            rgb,
            alpha,
        });
        self
    }

    /// Adds a box from x/y/z ranges.
    fn part(mut self, x: [f64; 2], y: [f64; 2], z: [f64; 2], material: usize) -> Self {
        self.parts.push(Part {
            min: [x[0], y[0], z[0]],
            max: [x[1], y[1], z[1]],
            material,
        });
        self
    }

    /// Four legs under a top of `w × d` at height `h` (leg thickness `t`).
    fn legs(mut self, w: f64, d: f64, h: f64, t: f64, material: usize) -> Self {
        for sx in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                let cx = sx * (w / 2.0 - t / 2.0 - 0.02);
                let cz = sz * (d / 2.0 - t / 2.0 - 0.02);
                self = self.part(
                    [cx - t / 2.0, cx + t / 2.0],
                    [0.0, h],
                    [cz - t / 2.0, cz + t / 2.0],
                    material,
                );
            }
        }
        self
    }

    fn finish(mut self) -> Self {
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        for p in &self.parts {
            for a in 0..3 {
                min[a] = min[a].min(p.min[a]);
                max[a] = max[a].max(p.max[a]);
            }
        }
        self.size = [max[0] - min[0], max[1], max[2] - min[2]];
        self
    }

    fn with_top(mut self, top: f64) -> Self {
        self.top = Some(top);
        self
    }
}

/// The model library with lookups by fine category.
#[derive(Debug)]
pub struct Catalog {
    /// All models, in a fixed order.
    pub models: Vec<ModelSpec>,
    by_fine: HashMap<&'static str, Vec<usize>>,
    by_id: HashMap<String, usize>,
}

impl Catalog {
    /// Indices of the models of a fine category.
    pub fn of(&self, fine: &str) -> &[usize] {
        self.by_fine.get(fine).map(Vec::as_slice).unwrap_or(&[])
    }

    /// The model with this id.
    pub fn get(&self, id: &str) -> Option<&ModelSpec> {
        self.by_id.get(id).map(|&i| &self.models[i])
    }
}

/// Storey height: floor to floor (metres).
pub const LEVEL_HEIGHT: f64 = 3.0;
/// Number of steps of a flight of stairs (rise 3.0 / 18 ≈ 0.167 m, below the 0.2 m climb).
pub const STAIR_STEPS: usize = 18;
/// Depth of one step.
pub const STAIR_RUN: f64 = 0.28;
/// Width of the stairs.
pub const STAIR_WIDTH: f64 = 1.0;
/// Height of door openings.
pub const DOOR_HEIGHT: f64 = 2.1;
/// Height of arch openings.
pub const ARCH_HEIGHT: f64 = 2.3;
/// Door widths of the library (opening width).
pub const DOOR_WIDTHS: [f64; 3] = [0.8, 0.9, 1.0];
/// Arch widths of the library.
pub const ARCH_WIDTHS: [f64; 3] = [1.2, 1.4, 1.6];
/// Window (width, height) pairs of the library.
pub const WINDOW_SIZES: [(f64, f64); 4] = [(0.8, 1.2), (1.2, 1.2), (1.6, 1.2), (0.6, 0.6)];
/// Thickness of door/window frames in walls (the combined wall thickness).
pub const FRAME_DEPTH: f64 = 0.15;

const WOODS: [[f64; 3]; 4] = [
    [0.55, 0.38, 0.22],
    [0.72, 0.56, 0.38],
    [0.35, 0.24, 0.15],
    [0.85, 0.78, 0.65],
];
const FABRICS: [[f64; 3]; 5] = [
    [0.25, 0.35, 0.55],
    [0.6, 0.2, 0.2],
    [0.45, 0.5, 0.4],
    [0.8, 0.75, 0.65],
    [0.3, 0.3, 0.32],
];
const WHITE: [f64; 3] = [0.92, 0.92, 0.9];
const METAL: [f64; 3] = [0.55, 0.56, 0.58];
const DARK: [f64; 3] = [0.08, 0.08, 0.1];

/// The library (built once).
pub fn catalog() -> &'static Catalog {
    static CATALOG: OnceLock<Catalog> = OnceLock::new();
    CATALOG.get_or_init(build)
}

fn variant_rng(fine: &str, k: usize) -> Rng {
    Rng::new(derive_seed(0, &["catalog", fine, &k.to_string()]))
}

fn pick(rng: &mut Rng, palette: &[[f64; 3]]) -> [f64; 3] {
    palette[rng.below(palette.len())]
}

fn build() -> Catalog {
    let mut models = Vec::new();
    let id = |fine: &str, k: usize| format!("g_{fine}_{k}");
    for k in 0..3 {
        let mut r = variant_rng("double_bed", k);
        let (w, d) = (1.5 + 0.15 * k as f64, 2.05);
        models.push(
            ModelSpec::new(id("double_bed", k), "double_bed", "bed", "bed")
                .mat("wood", pick(&mut r, &WOODS))
                .mat("textile", pick(&mut r, &FABRICS))
                .mat("pillow", WHITE)
                .part([-w / 2.0, w / 2.0], [0.0, 0.3], [-d / 2.0, d / 2.0], 0)
                .part(
                    [-w / 2.0 + 0.03, w / 2.0 - 0.03],
                    [0.3, 0.55],
                    [-d / 2.0 + 0.05, d / 2.0 - 0.03],
                    1,
                )
                .part(
                    [-w / 2.0, w / 2.0],
                    [0.0, 1.0],
                    [-d / 2.0, -d / 2.0 + 0.06],
                    0,
                )
                .part(
                    [-w / 2.0 + 0.1, -0.05],
                    [0.55, 0.67],
                    [-d / 2.0 + 0.08, -d / 2.0 + 0.5],
                    2,
                )
                .part(
                    [0.05, w / 2.0 - 0.1],
                    [0.55, 0.67],
                    [-d / 2.0 + 0.08, -d / 2.0 + 0.5],
                    2,
                )
                .finish(),
        );
    }
    for k in 0..2 {
        let mut r = variant_rng("single_bed", k);
        let (w, d) = (0.9 + 0.1 * k as f64, 2.0);
        models.push(
            ModelSpec::new(id("single_bed", k), "single_bed", "bed", "bed")
                .mat("wood", pick(&mut r, &WOODS))
                .mat("textile", pick(&mut r, &FABRICS))
                .part([-w / 2.0, w / 2.0], [0.0, 0.3], [-d / 2.0, d / 2.0], 0)
                .part(
                    [-w / 2.0 + 0.03, w / 2.0 - 0.03],
                    [0.3, 0.5],
                    [-d / 2.0 + 0.05, d / 2.0 - 0.03],
                    1,
                )
                .part(
                    [-w / 2.0, w / 2.0],
                    [0.0, 0.9],
                    [-d / 2.0, -d / 2.0 + 0.06],
                    0,
                )
                .finish(),
        );
    }
    for k in 0..2 {
        let mut r = variant_rng("stand", k);
        models.push(
            ModelSpec::new(id("stand", k), "stand", "stand", "night_stand")
                .mat("wood", pick(&mut r, &WOODS))
                .part([-0.22, 0.22], [0.0, 0.5 + 0.05 * k as f64], [-0.2, 0.2], 0)
                .with_top(0.5 + 0.05 * k as f64)
                .finish(),
        );
    }
    for k in 0..2 {
        let mut r = variant_rng("wardrobe_cabinet", k);
        let w = 1.0 + 0.6 * k as f64;
        models.push(
            ModelSpec::new(
                id("wardrobe_cabinet", k),
                "wardrobe_cabinet",
                "wardrobe_cabinet",
                "cabinet",
            )
            .mat("wood", pick(&mut r, &WOODS))
            .mat("handle", METAL)
            .part([-w / 2.0, w / 2.0], [0.0, 2.0], [-0.3, 0.3], 0)
            .part([-0.06, -0.03], [0.9, 1.2], [0.3, 0.33], 1)
            .part([0.03, 0.06], [0.9, 1.2], [0.3, 0.33], 1)
            .finish(),
        );
    }
    {
        let mut r = variant_rng("dresser", 0);
        models.push(
            ModelSpec::new(id("dresser", 0), "dresser", "dresser", "dresser")
                .mat("wood", pick(&mut r, &WOODS))
                .part([-0.6, 0.6], [0.0, 0.8], [-0.25, 0.25], 0)
                .with_top(0.8)
                .finish(),
        );
    }
    for k in 0..2 {
        let mut r = variant_rng("desk", k);
        let w = 1.2 + 0.2 * k as f64;
        models.push(
            ModelSpec::new(id("desk", k), "desk", "desk", "desk")
                .mat("wood", pick(&mut r, &WOODS))
                .part([-w / 2.0, w / 2.0], [0.72, 0.75], [-0.32, 0.32], 0)
                .part([-w / 2.0, -w / 2.0 + 0.04], [0.0, 0.72], [-0.32, 0.32], 0)
                .part([w / 2.0 - 0.04, w / 2.0], [0.0, 0.72], [-0.32, 0.32], 0)
                .with_top(0.75)
                .finish(),
        );
    }
    models.push(
        ModelSpec::new(id("office_chair", 0), "office_chair", "chair", "chair")
            .mat("fabric", DARK)
            .mat("metal", METAL)
            .part([-0.3, 0.3], [0.0, 0.05], [-0.3, 0.3], 1)
            .part([-0.03, 0.03], [0.05, 0.42], [-0.03, 0.03], 1)
            .part([-0.25, 0.25], [0.42, 0.5], [-0.25, 0.25], 0)
            .part([-0.23, 0.23], [0.5, 1.0], [-0.27, -0.21], 0)
            .finish(),
    );
    for k in 0..2 {
        let mut r = variant_rng("chair", k);
        models.push(
            ModelSpec::new(id("chair", k), "chair", "chair", "chair")
                .mat("wood", pick(&mut r, &WOODS))
                .mat("fabric", pick(&mut r, &FABRICS))
                .legs(0.44, 0.44, 0.42, 0.04, 0)
                .part([-0.22, 0.22], [0.42, 0.47], [-0.22, 0.22], 1)
                .part([-0.22, 0.22], [0.47, 0.92], [-0.22, -0.18], 0)
                .finish(),
        );
    }
    for k in 0..2 {
        let mut r = variant_rng("armchair", k);
        models.push(
            ModelSpec::new(id("armchair", k), "armchair", "chair", "chair")
                .mat("fabric", pick(&mut r, &FABRICS))
                .part([-0.4, 0.4], [0.0, 0.42], [-0.4, 0.4], 0)
                .part([-0.4, 0.4], [0.42, 0.85], [-0.4, -0.25], 0)
                .part([-0.4, -0.3], [0.42, 0.62], [-0.25, 0.4], 0)
                .part([0.3, 0.4], [0.42, 0.62], [-0.25, 0.4], 0)
                .finish(),
        );
    }
    for k in 0..3 {
        let mut r = variant_rng("sofa", k);
        let w = 1.8 + 0.3 * k as f64;
        models.push(
            ModelSpec::new(id("sofa", k), "sofa", "sofa", "sofa")
                .mat("fabric", pick(&mut r, &FABRICS))
                .mat("wood", pick(&mut r, &WOODS))
                .part([-w / 2.0, w / 2.0], [0.0, 0.1], [-0.42, 0.42], 1)
                .part([-w / 2.0, w / 2.0], [0.1, 0.42], [-0.42, 0.42], 0)
                .part([-w / 2.0, w / 2.0], [0.42, 0.85], [-0.42, -0.22], 0)
                .part([-w / 2.0, -w / 2.0 + 0.15], [0.42, 0.62], [-0.22, 0.42], 0)
                .part([w / 2.0 - 0.15, w / 2.0], [0.42, 0.62], [-0.22, 0.42], 0)
                .finish(),
        );
    }
    for k in 0..2 {
        let mut r = variant_rng("coffee_table", k);
        let w = 1.0 + 0.2 * k as f64;
        models.push(
            ModelSpec::new(id("coffee_table", k), "coffee_table", "table", "table")
                .mat("wood", pick(&mut r, &WOODS))
                .legs(w, 0.6, 0.42, 0.05, 0)
                .part([-w / 2.0, w / 2.0], [0.42, 0.45], [-0.3, 0.3], 0)
                .with_top(0.45)
                .finish(),
        );
    }
    for k in 0..3 {
        let mut r = variant_rng("dining_table", k);
        let w = 1.4 + 0.2 * k as f64;
        models.push(
            ModelSpec::new(id("dining_table", k), "dining_table", "table", "table")
                .mat("wood", pick(&mut r, &WOODS))
                .legs(w, 0.9, 0.72, 0.06, 0)
                .part([-w / 2.0, w / 2.0], [0.72, 0.76], [-0.45, 0.45], 0)
                .with_top(0.76)
                .finish(),
        );
    }
    {
        let mut r = variant_rng("tv_stand", 0);
        models.push(
            ModelSpec::new(id("tv_stand", 0), "tv_stand", "tv_stand", "cabinet")
                .mat("wood", pick(&mut r, &WOODS))
                .part([-0.7, 0.7], [0.0, 0.45], [-0.22, 0.22], 0)
                .with_top(0.45)
                .finish(),
        );
    }
    models.push(
        ModelSpec::new(
            id("television", 0),
            "television",
            "television",
            "television",
        )
        .mat("screen", DARK)
        .mat("metal", METAL)
        .part([-0.15, 0.15], [0.0, 0.02], [-0.1, 0.1], 1)
        .part([-0.03, 0.03], [0.02, 0.1], [-0.03, 0.03], 1)
        .part([-0.5, 0.5], [0.1, 0.7], [-0.03, 0.03], 0)
        .finish(),
    );
    for k in 0..2 {
        let mut r = variant_rng("bookshelf", k);
        let w = 0.8 + 0.2 * k as f64;
        let mut m = ModelSpec::new(id("bookshelf", k), "bookshelf", "shelving", "bookshelf")
            .mat("wood", pick(&mut r, &WOODS))
            .mat("books", pick(&mut r, &FABRICS))
            .part([-w / 2.0, w / 2.0], [0.0, 1.9], [-0.18, -0.15], 0)
            .part([-w / 2.0, -w / 2.0 + 0.03], [0.0, 1.9], [-0.15, 0.17], 0)
            .part([w / 2.0 - 0.03, w / 2.0], [0.0, 1.9], [-0.15, 0.17], 0);
        for s in 0..5 {
            let y = s as f64 * 0.46;
            m = m.part(
                [-w / 2.0 + 0.03, w / 2.0 - 0.03],
                [y, y + 0.03],
                [-0.15, 0.17],
                0,
            );
            if s < 4 {
                m = m.part(
                    [-w / 2.0 + 0.05, w / 2.0 - 0.15],
                    [y + 0.03, y + 0.3],
                    [-0.14, 0.1],
                    1,
                );
            }
        }
        models.push(m.finish());
    }
    {
        let mut r = variant_rng("shoes_cabinet", 0);
        models.push(
            ModelSpec::new(
                id("shoes_cabinet", 0),
                "shoes_cabinet",
                "shoes_cabinet",
                "cabinet",
            )
            .mat("wood", pick(&mut r, &WOODS))
            .part([-0.45, 0.45], [0.0, 1.0], [-0.17, 0.17], 0)
            .with_top(1.0)
            .finish(),
        );
    }
    for k in 0..2 {
        let w = 0.6 * (k + 1) as f64;
        models.push(
            ModelSpec::new(
                id("kitchen_cabinet", k),
                "kitchen_cabinet",
                "kitchen_cabinet",
                "counter",
            )
            .mat("front", if k == 0 { WHITE } else { WOODS[1] })
            .mat("counter", [0.3, 0.3, 0.3])
            .part([-w / 2.0, w / 2.0], [0.0, 0.86], [-0.3, 0.28], 0)
            .part([-w / 2.0, w / 2.0], [0.86, 0.9], [-0.3, 0.3], 1)
            .with_top(0.9)
            .finish(),
        );
    }
    models.push(
        ModelSpec::new(
            id("refrigerator", 0),
            "refrigerator",
            "kitchen_appliance",
            "refridgerator",
        )
        .mat("body", WHITE)
        .mat("handle", METAL)
        .part([-0.35, 0.35], [0.0, 1.8], [-0.33, 0.33], 0)
        .part([0.25, 0.28], [0.9, 1.5], [0.33, 0.36], 1)
        .finish(),
    );
    models.push(
        ModelSpec::new(
            id("range_oven", 0),
            "range_oven",
            "kitchen_appliance",
            "otherprop",
        )
        .mat("body", METAL)
        .mat("top", DARK)
        .part([-0.3, 0.3], [0.0, 0.86], [-0.3, 0.28], 0)
        .part([-0.3, 0.3], [0.86, 0.9], [-0.3, 0.3], 1)
        .finish(),
    );
    models.push(
        ModelSpec::new(id("sink", 0), "sink", "sink", "sink")
            .mat("cabinet", WHITE)
            .mat("basin", [0.85, 0.88, 0.9])
            .part([-0.3, 0.3], [0.0, 0.8], [-0.22, 0.2], 0)
            .part([-0.3, 0.3], [0.8, 0.88], [-0.22, 0.22], 1)
            .finish(),
    );
    models.push(
        ModelSpec::new(id("toilet", 0), "toilet", "toilet", "toilet")
            .mat("ceramic", WHITE)
            .part([-0.18, 0.18], [0.0, 0.4], [-0.1, 0.32], 0)
            .part([-0.2, 0.2], [0.0, 0.8], [-0.32, -0.1], 0)
            .finish(),
    );
    models.push(
        ModelSpec::new(id("bathtub", 0), "bathtub", "bathtub", "bathtub")
            .mat("ceramic", WHITE)
            .part([-0.8, 0.8], [0.0, 0.1], [-0.37, 0.37], 0)
            .part([-0.8, 0.8], [0.1, 0.55], [-0.37, -0.3], 0)
            .part([-0.8, 0.8], [0.1, 0.55], [0.3, 0.37], 0)
            .part([-0.8, -0.73], [0.1, 0.55], [-0.3, 0.3], 0)
            .part([0.73, 0.8], [0.1, 0.55], [-0.3, 0.3], 0)
            .finish(),
    );
    models.push(
        ModelSpec::new(id("shower", 0), "shower", "shower", "shower_curtain")
            .mat("tray", WHITE)
            .glass("glass", [0.8, 0.9, 0.95], 0.3)
            .part([-0.45, 0.45], [0.0, 0.08], [-0.45, 0.45], 0)
            .part([-0.45, 0.45], [0.08, 2.0], [0.43, 0.45], 1)
            .part([-0.45, -0.43], [0.08, 2.0], [-0.45, 0.43], 1)
            .finish(),
    );
    for k in 0..2 {
        let h = 0.9 + 0.4 * k as f64;
        models.push(
            ModelSpec::new(id("plant", k), "plant", "plant", "otherprop")
                .mat("pot", [0.6, 0.35, 0.25])
                .mat("leaves", [0.2, 0.5, 0.2])
                .part([-0.15, 0.15], [0.0, 0.3], [-0.15, 0.15], 0)
                .part([-0.22, 0.22], [0.3, h], [-0.22, 0.22], 1)
                .finish(),
        );
    }
    models.push(
        ModelSpec::new(id("floor_lamp", 0), "floor_lamp", "indoor_lamp", "lamp")
            .mat("metal", METAL)
            .mat("shade", [0.95, 0.9, 0.75])
            .part([-0.15, 0.15], [0.0, 0.03], [-0.15, 0.15], 0)
            .part([-0.015, 0.015], [0.03, 1.35], [-0.015, 0.015], 0)
            .part([-0.18, 0.18], [1.35, 1.6], [-0.18, 0.18], 1)
            .finish(),
    );
    models.push(
        ModelSpec::new(id("table_lamp", 0), "table_lamp", "indoor_lamp", "lamp")
            .mat("base", METAL)
            .mat("shade", [0.95, 0.9, 0.75])
            .part([-0.07, 0.07], [0.0, 0.25], [-0.07, 0.07], 0)
            .part([-0.12, 0.12], [0.25, 0.42], [-0.12, 0.12], 1)
            .finish(),
    );
    models.push(
        ModelSpec::new(id("candle", 0), "candle", "candle", "lamp")
            .mat("wax", [0.95, 0.93, 0.85])
            .part([-0.03, 0.03], [0.0, 0.15], [-0.03, 0.03], 0)
            .finish(),
    );
    models.push(
        ModelSpec::new(id("person", 0), "person", "person", "person")
            .mat("clothes", [0.2, 0.25, 0.4])
            .mat("skin", [0.85, 0.65, 0.5])
            .part([-0.2, -0.02], [0.0, 0.85], [-0.1, 0.1], 0)
            .part([0.02, 0.2], [0.0, 0.85], [-0.1, 0.1], 0)
            .part([-0.22, 0.22], [0.85, 1.45], [-0.12, 0.12], 0)
            .part([-0.1, 0.1], [1.45, 1.7], [-0.1, 0.1], 1)
            .finish(),
    );
    models.push(
        ModelSpec::new(
            id("outdoor_seating", 0),
            "outdoor_seating",
            "outdoor_seating",
            "chair",
        )
        .mat("metal", METAL)
        .legs(0.5, 0.5, 0.42, 0.03, 0)
        .part([-0.25, 0.25], [0.42, 0.45], [-0.25, 0.25], 0)
        .part([-0.25, 0.25], [0.45, 0.85], [-0.25, -0.22], 0)
        .finish(),
    );
    // Architecture-like objects, placed in wall openings. Their frames stay inside the opening
    // so they never overlap the wall.
    let half = FRAME_DEPTH / 2.0;
    for &w in &DOOR_WIDTHS {
        let cm = (w * 100.0).round() as u32;
        for open in [true, false] {
            let state = if open { "open" } else { "closed" };
            let mut m = ModelSpec::new(format!("g_door_{state}_{cm}"), "door", "door", "door")
                .mat("frame", WHITE)
                .mat("leaf", WOODS[(cm as usize / 10) % WOODS.len()])
                .mat("handle", METAL)
                .part(
                    [-w / 2.0, -w / 2.0 + 0.05],
                    [0.0, DOOR_HEIGHT],
                    [-half, half],
                    0,
                )
                .part(
                    [w / 2.0 - 0.05, w / 2.0],
                    [0.0, DOOR_HEIGHT],
                    [-half, half],
                    0,
                )
                .part(
                    [-w / 2.0 + 0.05, w / 2.0 - 0.05],
                    [DOOR_HEIGHT - 0.05, DOOR_HEIGHT],
                    [-half, half],
                    0,
                );
            let leaf_w = w - 0.1;
            if open {
                // Swung 90° into the +Z side, against the hinge jamb.
                let x0 = -w / 2.0 + 0.05;
                m = m.part(
                    [x0, x0 + 0.04],
                    [0.0, DOOR_HEIGHT - 0.06],
                    [half, half + leaf_w],
                    1,
                );
            } else {
                m = m
                    .part(
                        [-leaf_w / 2.0, leaf_w / 2.0],
                        [0.0, DOOR_HEIGHT - 0.06],
                        [-0.02, 0.02],
                        1,
                    )
                    .part(
                        [leaf_w / 2.0 - 0.12, leaf_w / 2.0 - 0.04],
                        [0.95, 1.0],
                        [0.02, 0.07],
                        2,
                    );
            }
            models.push(m.finish());
        }
    }
    for &w in &ARCH_WIDTHS {
        let cm = (w * 100.0).round() as u32;
        models.push(
            ModelSpec::new(format!("g_arch_{cm}"), "arch", "arch", "door")
                .mat("frame", WHITE)
                .part(
                    [-w / 2.0, -w / 2.0 + 0.06],
                    [0.0, ARCH_HEIGHT],
                    [-half, half],
                    0,
                )
                .part(
                    [w / 2.0 - 0.06, w / 2.0],
                    [0.0, ARCH_HEIGHT],
                    [-half, half],
                    0,
                )
                .part(
                    [-w / 2.0 + 0.06, w / 2.0 - 0.06],
                    [ARCH_HEIGHT - 0.12, ARCH_HEIGHT],
                    [-half, half],
                    0,
                )
                .finish(),
        );
    }
    for &(w, h) in &WINDOW_SIZES {
        let (cw, ch) = ((w * 100.0).round() as u32, (h * 100.0).round() as u32);
        models.push(
            ModelSpec::new(format!("g_window_{cw}x{ch}"), "window", "window", "window")
                .mat("frame", WHITE)
                .glass("glass", [0.75, 0.85, 0.95], 0.3)
                .part([-w / 2.0, -w / 2.0 + 0.05], [0.0, h], [-half, half], 0)
                .part([w / 2.0 - 0.05, w / 2.0], [0.0, h], [-half, half], 0)
                .part(
                    [-w / 2.0 + 0.05, w / 2.0 - 0.05],
                    [0.0, 0.05],
                    [-half, half],
                    0,
                )
                .part(
                    [-w / 2.0 + 0.05, w / 2.0 - 0.05],
                    [h - 0.05, h],
                    [-half, half],
                    0,
                )
                .part(
                    [-w / 2.0 + 0.05, w / 2.0 - 0.05],
                    [0.05, h - 0.05],
                    [-0.005, 0.005],
                    1,
                )
                .finish(),
        );
    }
    {
        let rise = LEVEL_HEIGHT / STAIR_STEPS as f64;
        let len = STAIR_STEPS as f64 * STAIR_RUN;
        let w = STAIR_WIDTH;
        let mut m =
            ModelSpec::new(id("stairs", 0), "stairs", "stairs", "floor").mat("step", WOODS[0]);
        // Step 0 at the front (+Z end); the flight rises towards -Z.
        for i in 0..STAIR_STEPS {
            let z1 = len / 2.0 - i as f64 * STAIR_RUN;
            m = m.part(
                [-w / 2.0, w / 2.0],
                [0.0, (i + 1) as f64 * rise],
                [z1 - STAIR_RUN, z1],
                0,
            );
        }
        models.push(m.finish());
    }
    let mut by_fine: HashMap<&'static str, Vec<usize>> = HashMap::new();
    let mut by_id = HashMap::new();
    for (i, m) in models.iter().enumerate() {
        by_fine.entry(m.fine).or_default().push(i);
        by_id.insert(m.id.clone(), i);
    }
    Catalog {
        models,
        by_fine,
        by_id,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_have_unique_ids_and_sane_sizes() {
        let c = catalog();
        assert_eq!(c.by_id.len(), c.models.len());
        for m in &c.models {
            assert!(
                m.size.iter().all(|s| *s > 0.0 && *s < 6.0),
                "{}: {:?}",
                m.id,
                m.size
            );
            assert!(
                m.parts.iter().all(|p| p.material < m.materials.len()),
                "{}",
                m.id
            );
            assert!(
                m.parts.iter().all(|p| (0..3).all(|a| p.min[a] < p.max[a])),
                "{}",
                m.id
            );
        }
        assert_eq!(c.of("door").len(), 6);
        assert!(c.get("g_stairs_0").is_some());
    }

    #[test]
    fn stairs_rise_below_the_default_climb_and_reach_the_next_level() {
        let s = catalog().get("g_stairs_0").unwrap();
        assert!((s.size[1] - LEVEL_HEIGHT).abs() < 1e-9);
        assert!(LEVEL_HEIGHT / (STAIR_STEPS as f64) < 0.2);
        // The top step is at the -Z end.
        let top = s.parts.last().unwrap();
        assert!(top.min[2] < -s.size[2] / 2.0 + STAIR_RUN);
    }
}
