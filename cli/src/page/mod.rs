//! The bench's page (`report.html`, crops in `report/`): for every scene, signal and budget, a
//! few frames after each event of the scene (an object or light starts moving, the camera cuts;
//! [`Scene::events`](vrrt_scene::Scene::events)), crops of the moving region side by side —
//! reference, raw, each configuration — with each one's error heatmap, so that lag and
//! ghosting are seen and not only counted.
//!
//! Crops are written as the frames go by and only their names and captions are kept, so memory
//! does not grow with the sequence.

mod crop;
mod html;
mod region;

use crate::outdir::OutDir;
use crate::session::{self, Config, FrameView, LoadedScene, SequenceOptions};
use anyhow::{Context, Result};
use region::Rect;
use std::path::PathBuf;
use std::rc::Rc;
use vrrt_backend::Backend;
use vrrt_scene::image::{write_heatmap_png, write_png, Image};
use vrrt_scene::render::Signal;
use vrrt_scene::{Event, EventKind};

/// The page, in the bench's output directory.
pub const PAGE: &str = "report.html";
/// The folder of its images, beside it.
pub const DIR: &str = "report";
/// Frames shown after each event (the event's frame is `+0`): the first frames show the
/// disocclusion and the lag at its worst, `+4` and `+8` how long ghosts and stale shading
/// last (history lengths are tens of frames), `+16` whether it has converged again.
pub const WINDOW: [u32; 6] = [0, 1, 2, 4, 8, 16];
/// The heatmaps' scale: `|test − reference|` (mean over channels) from 0 (black) through blue,
/// green and yellow to red at this value; white above it, magenta where not finite. The same
/// for every configuration, so that their heatmaps compare.
pub const ERROR_MAX: f32 = 0.25;

/// One image of the page and its caption.
#[derive(Clone, Debug)]
struct Tile {
    /// File name inside [`DIR`].
    file: String,
    caption: String,
}

/// A column of a section: its images and, below each, its error heatmap (for the reference
/// column: the moving mask), one per row.
#[derive(Clone, Debug)]
struct Column {
    /// Who it is: `reference`, `samples` (the raw samples) or a configuration's name (also in
    /// its file names).
    key: String,
    title: String,
    images: Vec<Option<Tile>>,
    errors: Vec<Option<Tile>>,
}

/// One event of one scene, signal (part) and budget.
#[derive(Clone, Debug)]
struct Section {
    scene: String,
    /// The signal, with the part for `all` ("all: ao").
    signal: String,
    budget: f32,
    event: Event,
    size: (u32, u32),
    /// The crop; `None` when the event's object is out of view in these frames.
    crop: Option<Rect>,
    /// Frames shown ([`WINDOW`] after the event, within the frames rendered).
    rows: Vec<u32>,
    columns: Vec<Column>,
}

/// A scene's events, for the list at the top of the page.
#[derive(Clone, Debug)]
struct SceneEvents {
    key: String,
    frames: u32,
    events: Vec<Event>,
}

/// The page being assembled over a bench.
pub struct Page {
    out: Rc<OutDir>,
    enabled: bool,
    /// The backend whose frames the page shows (the first one the bench opens).
    backend: Option<String>,
    spp: u32,
    scenes: Vec<SceneEvents>,
    sections: Vec<Section>,
}

impl Page {
    /// A page in `out` (whose preparation removed an earlier bench's page, as every file that
    /// bench wrote, also when `enabled` is false, so no stale page is left beside new results).
    pub fn new(out: Rc<OutDir>, enabled: bool) -> Page {
        Page {
            out,
            enabled,
            backend: None,
            spp: 0,
            scenes: Vec::new(),
            sections: Vec::new(),
        }
    }

    /// Starts one sequence (one configuration at one budget): finds or opens the sections of
    /// its scene, signal and budget. Its [`Shots::frame`] then takes the sequence's frames.
    /// Only the first backend's sequences are shown (the others render the same frames).
    pub fn sequence(
        &mut self,
        exec: &Backend,
        scene: &LoadedScene,
        opts: &SequenceOptions,
    ) -> Shots<'_> {
        let backend = {
            use vrrt_core::executor::Executor;
            exec.name().to_string()
        };
        if !self.enabled || self.backend.get_or_insert(backend.clone()) != &backend {
            return Shots {
                page: self,
                config: opts.config,
                targets: Vec::new(),
            };
        }
        self.spp = opts.spp;
        let events = scene.scene.events();
        if !self.scenes.iter().any(|s| s.key == scene.key) {
            self.scenes.push(SceneEvents {
                key: scene.key.clone(),
                frames: opts.frames,
                events: events.clone(),
            });
        }
        let parts = session::parts(opts.signal, scene.scene.lights.len());
        let mut targets = Vec::new();
        for (k, part) in parts.iter().enumerate() {
            let signal = match opts.signal {
                Signal::All { .. } => format!("all: {}", part.name),
                _ => part.name.to_string(),
            };
            for event in events.iter().filter(|e| e.frame < opts.frames) {
                // Ambient occlusion does not see lights: nothing of a light's event shows.
                let unseen = matches!(event.kind, EventKind::LightStarts { .. })
                    && matches!(part.signal, Signal::Ao { .. });
                if unseen {
                    continue;
                }
                let found = self.sections.iter().position(|s| {
                    s.scene == scene.key
                        && s.signal == signal
                        && s.budget == opts.rpp
                        && s.event == *event
                });
                let index = found.unwrap_or_else(|| {
                    let rows: Vec<u32> = WINDOW
                        .iter()
                        .map(|o| event.frame + o)
                        .filter(|&f| f < opts.frames)
                        .collect();
                    self.sections.push(Section {
                        scene: scene.key.clone(),
                        signal: signal.clone(),
                        budget: opts.rpp,
                        event: event.clone(),
                        size: opts.size,
                        crop: region::crop(&scene.scene, event, &rows, opts.size),
                        rows,
                        columns: Vec::new(),
                    });
                    self.sections.len() - 1
                });
                targets.push((index, k));
            }
        }
        Shots {
            page: self,
            config: opts.config,
            targets,
        }
    }

    /// Writes `report.html` (nothing when disabled) and says where.
    pub fn write(&self) -> Result<()> {
        if !self.enabled {
            return Ok(());
        }
        let legend = html::legend(ERROR_MAX);
        let legend_path = self.out.file(&format!("{DIR}/{}", html::LEGEND))?;
        write_heatmap_png(legend_path, legend.view(), ERROR_MAX)
            .context("writing the page's legend")?;
        let text = html::page(&html::Meta {
            backend: self.backend.as_deref().unwrap_or("none"),
            spp: self.spp,
            scenes: &self.scenes,
            sections: &self.sections,
        });
        let path = self.out.write(PAGE, text.as_bytes())?;
        println!(
            "page: {} ({} sections, images in {})",
            path.display(),
            self.sections.len(),
            self.out.dir().join(DIR).display()
        );
        Ok(())
    }
}

/// Takes one sequence's frames for the page (see [`Page::sequence`]).
pub struct Shots<'p> {
    page: &'p mut Page,
    config: Config,
    /// (section, part index) pairs this sequence fills.
    targets: Vec<(usize, usize)>,
}

impl Shots<'_> {
    /// Crops a frame into the sections that show it (frames without a reference, as in the
    /// bench's timing repeats, are skipped).
    pub fn frame(&mut self, v: &FrameView<'_>) -> Result<()> {
        let frame = v.record.frame;
        let dir = &*self.page.out;
        for &(index, k) in &self.targets {
            let section = &mut self.page.sections[index];
            let (Some(row), Some(crop), Some(p)) = (
                section.rows.iter().position(|&f| f == frame),
                section.crop,
                v.parts.get(k),
            ) else {
                continue;
            };
            let Some(reference) = &p.reference else {
                continue;
            };
            let writer = Writer {
                dir,
                stem: format!("s{index:03}_f{frame:04}"),
                crop,
                scale: crop.display_scale(),
                reference,
            };
            let rows = section.rows.len();
            let config = self.config.name();
            // The reference and the raw samples come from the first configuration to render
            // the section; the moving mask too (its disocclusion half is the configuration's).
            let width = section.size.0;
            let r = column(&mut section.columns, "reference", rows, || {
                "reference".into()
            });
            if r.images[row].is_none() {
                r.images[row] = Some(writer.image("reference", reference, None)?);
                r.errors[row] = match &p.moving {
                    Some(m) => Some(writer.mask(m, width, config)?),
                    None => None,
                };
            }
            let raw = column(&mut section.columns, "samples", rows, || {
                format!("raw samples (as traced for {config})")
            });
            if raw.images[row].is_none() {
                (raw.images[row], raw.errors[row]) = writer.pair("samples", &p.raw)?;
            }
            let c = column(&mut section.columns, config, rows, || config.into());
            (c.images[row], c.errors[row]) = writer.pair(config, &p.test)?;
        }
        Ok(())
    }
}

/// The column `key` of a section, added (titled `title()`) if it is not there yet.
fn column<'c>(
    columns: &'c mut Vec<Column>,
    key: &str,
    rows: usize,
    title: impl FnOnce() -> String,
) -> &'c mut Column {
    let i = match columns.iter().position(|c| c.key == key) {
        Some(i) => i,
        None => {
            columns.push(Column {
                key: key.to_string(),
                title: title(),
                images: vec![None; rows],
                errors: vec![None; rows],
            });
            columns.len() - 1
        }
    };
    &mut columns[i]
}

/// Writes one frame's crops of one section.
struct Writer<'a> {
    dir: &'a OutDir,
    stem: String,
    crop: Rect,
    scale: u32,
    reference: &'a Image,
}

impl Writer<'_> {
    fn path(&self, what: &str) -> Result<(PathBuf, String)> {
        let file = format!("{}_{what}.png", self.stem);
        Ok((self.dir.file(&format!("{DIR}/{file}"))?, file))
    }

    /// The crop of `image`, captioned with its relMSE (none for the reference itself).
    fn image(&self, what: &str, image: &Image, relmse: Option<f64>) -> Result<Tile> {
        let (path, file) = self.path(what)?;
        write_png(&path, crop::cut(image, self.crop, self.scale).view())?;
        let caption = relmse.map_or(String::new(), |v| format!("relMSE {}", session::fmt(v, 5)));
        Ok(Tile { file, caption })
    }

    /// The crop of `test` and its error heatmap.
    fn pair(&self, what: &str, test: &Image) -> Result<(Option<Tile>, Option<Tile>)> {
        let relmse = crop::rel_mse(test, self.reference, self.crop)?;
        let image = self.image(what, test, Some(relmse))?;
        let error = crop::error(test, self.reference, self.crop, self.scale);
        let (path, file) = self.path(&format!("{what}_error"))?;
        write_heatmap_png(&path, error.view(), ERROR_MAX)?;
        let caption = format!(
            "mean |error| {}",
            session::fmt(crop::mean_finite(&error), 4)
        );
        Ok((Some(image), Some(Tile { file, caption })))
    }

    /// The moving mask's crop (white: moving), as the configuration `config` flagged it.
    fn mask(&self, moving: &[bool], width: u32, config: &str) -> Result<Tile> {
        let (path, file) = self.path("moving")?;
        write_png(
            &path,
            crop::mask(moving, width, self.crop, self.scale).view(),
        )?;
        Ok(Tile {
            file,
            caption: format!("moving mask ({config})"),
        })
    }
}
