//! Images the command line writes: panels of rendered frames, text labels set in the editor's
//! own typeface (egui's Ubuntu Light, rasterised with `ab_glyph`, antialiased), the step-count
//! colour bar, and atomic PNG output.

use std::path::Path;
use std::sync::LazyLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use skeletrace_core::frame::{Frame, StepScale, StepSummary, heat_colour, shared_step_top, srgb8};

/// Text size of labels and the colour bar, in pixels.
const TEXT_PX: usize = 18;
/// Text size of the labels of narrow panels.
const SMALL_TEXT_PX: usize = 12;
/// Panels at least this wide get their labels large on two lines; narrower ones small on three.
const WIDE_PANEL: usize = 400;
/// Height of the colour bar strip, tick labels included.
pub const BAR_HEIGHT: usize = 26 + TEXT_PX + 10;

/// The editor's proportional typeface.
static TYPEFACE: LazyLock<Option<FontRef<'static>>> =
    LazyLock::new(|| FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT).ok());

/// An sRGB RGBA8 image.
pub struct Canvas {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    pixels: Vec<[u8; 4]>,
}

impl Canvas {
    /// A canvas filled with `colour`.
    #[must_use]
    pub fn new(width: usize, height: usize, colour: [u8; 4]) -> Self {
        Self {
            width,
            height,
            pixels: vec![colour; width * height],
        }
    }

    /// The pixels as RGBA bytes, row-major from the top-left.
    #[must_use]
    pub fn bytes(&self) -> &[u8] {
        self.pixels.as_flattened()
    }

    /// Sets a pixel, ignoring coordinates outside the canvas.
    pub fn put(&mut self, x: usize, y: usize, colour: [u8; 4]) {
        if x < self.width && y < self.height {
            self.pixels[y * self.width + x] = colour;
        }
    }

    /// Fills a rectangle.
    pub fn fill(&mut self, x: usize, y: usize, w: usize, h: usize, colour: [u8; 4]) {
        for yy in y..(y + h).min(self.height) {
            for xx in x..(x + w).min(self.width) {
                self.pixels[yy * self.width + xx] = colour;
            }
        }
    }

    /// Draws a frame's shaded colours with its top-left corner at `(x, y)`.
    pub fn draw_shaded(&mut self, frame: &Frame, x: usize, y: usize) {
        for (i, c) in frame.colour.iter().enumerate() {
            let colour = [srgb8(c[0]), srgb8(c[1]), srgb8(c[2]), 255];
            self.put(x + i % frame.width, y + i / frame.width, colour);
        }
    }

    /// Draws a frame's step counts as a heat map on the scale `[0, steps_max]`.
    pub fn draw_steps(
        &mut self,
        frame: &Frame,
        steps_max: u32,
        scale: StepScale,
        x: usize,
        y: usize,
    ) {
        for (i, &s) in frame.steps.iter().enumerate() {
            let colour = heat_rgba(scale.position(f64::from(s), steps_max));
            self.put(x + i % frame.width, y + i / frame.width, colour);
        }
    }

    /// Width in pixels of `text` when drawn at the labels' size.
    #[must_use]
    pub fn text_width(text: &str) -> usize {
        text_width_px(text, TEXT_PX)
    }

    /// Draws `text` at the labels' size with its top-left corner at `(x, y)`.
    pub fn text(&mut self, x: usize, y: usize, text: &str, colour: [u8; 4]) {
        self.text_px(x, y, text, colour, TEXT_PX);
    }

    /// Draws `text` `px` pixels high (the typeface's ascent to descent) with its top-left corner
    /// at `(x, y)`, blending each glyph's coverage over the canvas.
    fn text_px(&mut self, x: usize, y: usize, text: &str, colour: [u8; 4], px: usize) {
        let Some(font) = TYPEFACE.as_ref() else {
            return;
        };
        let ascent = font.as_scaled(PxScale::from(px as f32)).ascent();
        let (glyphs, _) = lay_out(font, text, px, (x as f32, y as f32 + ascent));
        for glyph in glyphs {
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let (px, py) = (bounds.min.x + gx as f32, bounds.min.y + gy as f32);
                if px >= 0.0 && py >= 0.0 {
                    self.blend(px as usize, py as usize, colour, coverage);
                }
            });
        }
    }

    /// Blends `colour` over a pixel with opacity `alpha`, ignoring coordinates outside.
    fn blend(&mut self, x: usize, y: usize, colour: [u8; 4], alpha: f32) {
        if x >= self.width || y >= self.height {
            return;
        }
        let a = alpha.clamp(0.0, 1.0);
        let p = &mut self.pixels[y * self.width + x];
        for k in 0..3 {
            p[k] = (f32::from(p[k]) * (1.0 - a) + f32::from(colour[k]) * a).round() as u8;
        }
    }

    /// Height of the label strip of a panel `width` pixels wide.
    #[must_use]
    pub fn label_height(width: usize) -> usize {
        if width >= WIDE_PANEL {
            2 * (TEXT_PX + 6) + 6
        } else {
            3 * (SMALL_TEXT_PX + 4) + 6
        }
    }

    /// A method's label strip: its name, then its average, median and maximum steps (two
    /// large lines on wide panels, three small ones on narrow ones).
    pub fn label(&mut self, x: usize, y: usize, width: usize, name: &str, s: StepSummary) {
        self.fill(x, y, width, Self::label_height(width), [24, 26, 30, 255]);
        let average = format!("avg {:.2}", s.average);
        let rest = format!("med {}  max {}", s.median, s.max);
        let (px, gap, lines) = if width >= WIDE_PANEL {
            (
                TEXT_PX,
                6,
                vec![name.to_owned(), format!("{average}  {rest}")],
            )
        } else {
            (SMALL_TEXT_PX, 4, vec![name.to_owned(), average, rest])
        };
        for (i, line) in lines.iter().enumerate() {
            let colour = if i == 0 {
                [250, 250, 250, 255]
            } else {
                [190, 195, 205, 255]
            };
            self.text_px(x + 6, y + 4 + i * (px + gap), line, colour, px);
        }
    }

    /// The colour bar of the step-count scale `[0, steps_max]`, titled "steps" (or "steps, log"),
    /// with tick labels that do not overlap: quarters of the range on a linear scale, 0, 1, 2, 5,
    /// 10, 20, 50, … on a logarithmic one, and the top. Counts above the scale take its top
    /// colour (`clipped` marks the last label `>=`).
    pub fn colour_bar(
        &mut self,
        x: usize,
        y: usize,
        width: usize,
        steps_max: u32,
        scale: StepScale,
        clipped: bool,
    ) {
        let white = [235, 235, 235, 255];
        self.fill(x, y, width, BAR_HEIGHT, [24, 26, 30, 255]);
        let title = match scale {
            StepScale::Log => "steps, log",
            StepScale::Linear => "steps",
        };
        self.text(x + 8, y + 6, title, white);
        let bar_x = x + 16 + Self::text_width(title);
        let bar_w = (x + width).saturating_sub(bar_x + 16).max(1);
        for i in 0..bar_w {
            let c = heat_rgba(i as f64 / (bar_w - 1).max(1) as f64);
            self.fill(bar_x + i, y + 8, 1, 14, c);
        }
        let top = steps_max.max(1);
        let mut values: Vec<u32> = match scale {
            StepScale::Linear => (0..4u32).map(|k| (top * k + 2) / 4).collect(),
            StepScale::Log => std::iter::once(0)
                .chain((0..10).flat_map(|e| [1, 2, 5].map(|m| m * 10u32.pow(e))))
                .take_while(|&v| v < top)
                .collect(),
        };
        values.push(top);
        // The top label first: it must show; then the others, left to right, where they fit.
        let last = values.len() - 1;
        let mut order: Vec<usize> = (0..last).collect();
        order.insert(0, last);
        let mut placed: Vec<(usize, usize)> = Vec::new();
        for k in order {
            let value = values[k];
            let text = if k == last && clipped {
                format!(">={value}")
            } else {
                value.to_string()
            };
            let position = scale.position(f64::from(value), top);
            let tick = bar_x + ((bar_w - 1) as f64 * position).round() as usize;
            self.fill(tick, y + 22, 1, 4, white);
            let w = Self::text_width(&text);
            let tx = tick
                .saturating_sub(w / 2)
                .min((x + width).saturating_sub(w + 2))
                .max(x + 2);
            let overlaps = placed.iter().any(|&(a, b)| tx < b + 8 && a < tx + w + 8);
            if !overlaps {
                self.text(tx, y + 27, &text, white);
                placed.push((tx, tx + w));
            }
        }
    }

    /// Writes the canvas as a PNG through `skeletrace_core::output` (atomic, never over one of
    /// `inputs`).
    ///
    /// # Errors
    /// A message naming the file.
    pub fn save_png(&self, path: &Path, inputs: &[&Path]) -> Result<(), String> {
        let fail = |e: &dyn std::fmt::Display| format!("{}: cannot write: {e}", path.display());
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| fail(&e))?;
        let pixels: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        writer.write_image_data(&pixels).map_err(|e| fail(&e))?;
        writer.finish().map_err(|e| fail(&e))?;
        skeletrace_core::output::write_file(path, &bytes, inputs).map_err(|e| e.to_string())
    }
}

/// Width in pixels of `text` set `px` pixels high in the labels' typeface.
fn text_width_px(text: &str, px: usize) -> usize {
    TYPEFACE.as_ref().map_or(0, |font| {
        lay_out(font, text, px, (0.0, 0.0)).1.ceil() as usize
    })
}

/// `text`'s glyphs set `px` pixels high with the baseline starting at `origin` (advances and
/// kerning), and the caret's x after the last one.
fn lay_out(
    font: &FontRef<'static>,
    text: &str,
    px: usize,
    origin: (f32, f32),
) -> (Vec<ab_glyph::Glyph>, f32) {
    let scaled = font.as_scaled(PxScale::from(px as f32));
    let mut caret = point(origin.0, origin.1);
    let mut previous = None;
    let glyphs = text
        .chars()
        .map(|ch| {
            let id = scaled.glyph_id(ch);
            if let Some(p) = previous {
                caret.x += scaled.kern(p, id);
            }
            previous = Some(id);
            let glyph = id.with_scale_and_position(px as f32, caret);
            caret.x += scaled.h_advance(id);
            glyph
        })
        .collect();
    (glyphs, caret.x)
}

/// Heat-map colour as RGBA8.
fn heat_rgba(x: f64) -> [u8; 4] {
    let [r, g, b] = heat_colour(x);
    let byte = |v: f32| (v * 255.0 + 0.5) as u8;
    [byte(r), byte(g), byte(b), 255]
}

/// The shared top of the colour scale: the largest 99th percentile, over the panels, of the
/// step counts of pixels whose ray met a support (a single outlier pixel would otherwise
/// darken every panel; counts above it are drawn in the top colour and the bar says so).
pub fn shared_scale(frames: &[(&str, Frame)]) -> u32 {
    let histograms: Vec<_> = frames.iter().map(|(_, f)| f.step_histogram()).collect();
    shared_step_top(&histograms)
}

/// Panels per row of a composed picture.
pub const COLUMNS: usize = 4;

/// What the panels of a composed picture show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Panels {
    /// Shaded frames, labelled with their method when `labelled`.
    Shaded {
        /// Draw each panel's method name and step summary above it.
        labelled: bool,
    },
    /// Step-count heat maps on `[0, steps_max]`, labelled, with the colour bar.
    Steps {
        /// Top of the shared scale.
        steps_max: u32,
        /// Logarithmic or linear.
        scale: StepScale,
        /// Some pixel exceeds `steps_max` (the bar says `>=`).
        clipped: bool,
    },
}

/// Lays out the panels (labelled when comparing or showing steps, four per row) and the
/// colour bar.
#[must_use]
pub fn compose(frames: &[(&str, Frame)], panels: Panels) -> Canvas {
    let Some((_, first)) = frames.first() else {
        return Canvas::new(1, 1, [0, 0, 0, 255]);
    };
    let (w, h) = (first.width, first.height);
    let labelled = match panels {
        Panels::Shaded { labelled } => labelled,
        Panels::Steps { .. } => true,
    };
    let label = if labelled { Canvas::label_height(w) } else { 0 };
    let columns = frames.len().min(COLUMNS);
    let rows = frames.len().div_ceil(COLUMNS);
    let bar = if matches!(panels, Panels::Steps { .. }) {
        BAR_HEIGHT
    } else {
        0
    };
    let mut canvas = Canvas::new(columns * w, rows * (h + label) + bar, [24, 26, 30, 255]);
    for (i, (name, frame)) in frames.iter().enumerate() {
        let (x, y) = ((i % COLUMNS) * w, (i / COLUMNS) * (h + label));
        if labelled {
            canvas.label(x, y, w, name, frame.step_summary());
        }
        match panels {
            Panels::Shaded { .. } => canvas.draw_shaded(frame, x, y + label),
            Panels::Steps {
                steps_max, scale, ..
            } => canvas.draw_steps(frame, steps_max, scale, x, y + label),
        }
    }
    if let Panels::Steps {
        steps_max,
        scale,
        clipped,
    } = panels
    {
        canvas.colour_bar(
            0,
            rows * (h + label),
            columns * w,
            steps_max,
            scale,
            clipped,
        );
    }
    canvas
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Labels are set in the editor's typeface: antialiased (coverage between 0 and 1 gives
    /// intermediate greys), proportional (an `i` is narrower than an `m`), within the box
    /// `text_width × TEXT_PX` below the given corner, and characters beyond ASCII (`≥`, `σ`)
    /// are drawn rather than replaced.
    #[test]
    fn labels_are_antialiased_proportional_and_stay_in_their_box() {
        let font = TYPEFACE.as_ref();
        assert!(font.is_some(), "the typeface loads");
        assert!(text_width_px("iiii", TEXT_PX) < text_width_px("mmmm", TEXT_PX));
        let text = "quadratic-taylor ≥ σ";
        let width = Canvas::text_width(text);
        let mut canvas = Canvas::new(width + 40, TEXT_PX + 40, [0, 0, 0, 255]);
        canvas.text(20, 20, text, [255, 255, 255, 255]);
        let mut lit = 0;
        let mut grey = 0;
        for y in 0..canvas.height {
            for x in 0..canvas.width {
                let v = canvas.pixels[y * canvas.width + x][0];
                if v > 0 {
                    lit += 1;
                    assert!(
                        (18..=22 + width).contains(&x) && (18..=24 + TEXT_PX).contains(&y),
                        "ink at ({x}, {y}) outside the text box"
                    );
                }
                grey += usize::from(v > 20 && v < 235);
            }
        }
        assert!(lit > 100 && grey > 20, "{lit} lit, {grey} grey pixels");
        // The two symbols alone leave ink too.
        let mut symbols = Canvas::new(60, 40, [0, 0, 0, 255]);
        symbols.text(4, 4, "≥σ", [255, 255, 255, 255]);
        assert!(symbols.pixels.iter().filter(|p| p[0] > 128).count() > 10);
    }
}
