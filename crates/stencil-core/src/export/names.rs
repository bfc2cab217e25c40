//! The names `make` owns in its output folder: a stencil's files, and a set's folders and files.
//! A leaf: the writer of one stencil (`pipeline`) and of a set (`layers`) both read it, so
//! neither needs the other for its names.

/// Every name `encode_outputs` can write: `make` owns these names in its output folder, and
/// removes those a run does not write (an earlier run's `stencil.gcode` must not sit beside a new
/// stencil, where `send` would stream it).
pub const OUTPUT_NAMES: &[&str] = &[
    "gray.png",
    "twotone.png",
    "stencil.png",
    "preview.png",
    "stencil.svg",
    "stencil.dxf",
    "mask.png",
    "mask.svg",
    "mask-front.png",
    "mask-front.svg",
    "mask-back.png",
    "mask-back.svg",
    "stencil.gcode",
    "stencil.plt",
    "report.json",
];

/// Folders a set's stencils may be in, besides the output folder itself.
pub const FOLDERS: &[&str] = &[
    "layer-1", "layer-2", "layer-3", "layer-4", "layer-5", "layer-6", "fill-in",
];

/// Every name `make` owns in its output folder: a one-layer run's files, a set's `composite.png`
/// and `layers.json`, every file of every layer folder and of `fill-in/`, and a tiled stencil's `tiles.png` and
/// tile folders (each with its layer folders or its `fill-in/`). Any run removes the
/// owned names it does not write, so a one-layer run leaves no layer folder behind.
pub fn owned_names() -> &'static [&'static str] {
    static NAMES: std::sync::OnceLock<Vec<&'static str>> = std::sync::OnceLock::new();
    NAMES.get_or_init(|| {
        // Some twenty thousand names, made every run: written end to end into one text (kept
        // for the program's life, as the names are) and cut at their ends, not formatted and
        // allocated one by one (a tenth of a 1 MP photo's `make` was this and the swap's sets).
        let mut text = String::new();
        let mut ends = Vec::new();
        let mut add = |parts: &[&str]| {
            for p in parts {
                text.push_str(p);
            }
            ends.push(text.len());
        };
        let most = crate::limits::MAX_TILES_PER_SIDE;
        for r in 1..=most {
            for c in 1..=most {
                let tile = format!("tile-{r}-{c}/");
                for n in OUTPUT_NAMES {
                    add(&[&tile, n]);
                    for f in FOLDERS {
                        add(&[&tile, f, "/", n]);
                    }
                }
            }
        }
        for f in FOLDERS {
            for n in OUTPUT_NAMES {
                add(&[f, "/", n]);
            }
        }
        let text: &'static str = Box::leak(text.into_boxed_str());
        let mut v: Vec<&'static str> = OUTPUT_NAMES.to_vec();
        v.push("composite.png");
        v.push("layers.json");
        // A tiled stencil's map and tile folders (`tiles`).
        v.push("tiles.png");
        let mut start = 0;
        for end in ends {
            v.push(&text[start..end]);
            start = end;
        }
        v
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names cut from one text are the names formatted one by one, in the same order:
    /// the files, the set's, then each tile's (its files and its layer folders' files in
    /// turn) and each layer folder's; none twice.
    #[test]
    fn owned_names_are_each_formatted_name_in_order() {
        let mut want: Vec<String> = OUTPUT_NAMES.iter().map(|n| n.to_string()).collect();
        want.extend(["composite.png", "layers.json", "tiles.png"].map(String::from));
        let most = crate::limits::MAX_TILES_PER_SIDE;
        for r in 1..=most {
            for c in 1..=most {
                for n in OUTPUT_NAMES {
                    want.push(format!("tile-{r}-{c}/{n}"));
                    for f in FOLDERS {
                        want.push(format!("tile-{r}-{c}/{f}/{n}"));
                    }
                }
            }
        }
        for f in FOLDERS {
            for n in OUTPUT_NAMES {
                want.push(format!("{f}/{n}"));
            }
        }
        assert_eq!(owned_names(), want);
        let unique: std::collections::HashSet<_> = owned_names().iter().collect();
        assert_eq!(unique.len(), want.len());
    }
}
