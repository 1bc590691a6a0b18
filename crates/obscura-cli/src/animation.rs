//! `obscura render --frames A-B` of an animated scene (glTF): each frame posed at its own time,
//! rendered with its flow toward its neighbours, written with its sidecars; complete frames are
//! skipped, so an interrupted sequence resumes where it stopped.

use std::path::Path;

use obscura_host::CameraDesc;
use obscura_render::frame::{self, Neighbours};
use obscura_render::job::{self, Overrides};

use crate::stdout::outln;
use obscura_render::render::{RenderOptions, prepare};
use obscura_render::sequence::frame_displays;
use obscura_scene::{Aov, Display, Scene};
use obscura_sdk::{Format, Registry};

/// Reads `--aov`: one AOV name, or `all` for every ground-truth AOV and the texture AOVs (`albedo`,
/// `uv`).
pub fn parse_aovs(text: &str) -> Result<Vec<Aov>, String> {
    if text == "all" {
        return Ok(Aov::GROUND_TRUTH.into_iter().chain(Aov::TEXTURE).collect());
    }
    Aov::from_name(text).map(|a| vec![a]).ok_or_else(|| {
        let names: Vec<&str> = (Aov::GROUND_TRUTH.iter().chain(&Aov::TEXTURE))
            .map(|a| a.name())
            .collect();
        format!(
            "unknown AOV '{text}'; expected one of {}, or all",
            names.join(", ")
        )
    })
}

/// Reads `--fps`: a positive finite number.
pub fn parse_fps(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{text}' is not a positive number of frames per second")),
    }
}

/// An animated scene's sequence job.
pub struct Animation<'a> {
    /// The scene file.
    pub path: &'a Path,
    /// Frames per second: frame N is posed at (N − 1)/fps seconds.
    pub fps: f32,
    /// The image size of the reader's camera (before overrides).
    pub format: Format,
    /// `obscura render`'s options applied to every frame's scene.
    pub overrides: &'a Overrides,
    /// The projection rendered through (loaded already).
    pub projection: &'a str,
    /// Where relative paths of the scene are read from.
    pub base_dir: &'a Path,
    /// The displays, before frame numbering.
    pub displays: &'a [Display],
    /// Render options.
    pub opts: &'a RenderOptions,
    /// No summaries.
    pub quiet: bool,
}

impl Animation<'_> {
    /// The scene of `frame`, with the overrides applied.
    fn scene(&self, frame: u32) -> Result<Scene, String> {
        let seconds = (frame as f32 - 1.0) / self.fps;
        let mut s =
            obscura_render::staging::load_gltf_at(self.path, CameraDesc::new(self.format), seconds, self.fps)
                .map_err(|e| e.to_string())?;
        self.overrides.apply(&mut s).map_err(|e| e.to_string())?;
        s.projection = self.projection.to_string();
        Ok(s)
    }

    /// Renders `frames` in order; a frame whose files are complete is skipped. Flow crosses to the
    /// neighbouring frames of the animation, selected or not: `flowForward` to frame N + 1's shutter
    /// open, `flowBackward` to frame N − 1's, written from frame 2 on (frame 1 is the animation's
    /// start).
    pub fn render(&self, frames: &[u32], registry: &mut Registry) -> Result<(), String> {
        let several = frames.len() > 1;
        let mut skipped = 0;
        // The textures and the automatic framing are the same at every frame: told once.
        let mut told = false;
        for &n in frames {
            let displays = frame::without_backward_flow(&frame_displays(self.displays, n, several), n > 1);
            if frame::is_complete(&displays) {
                skipped += 1;
                continue;
            }
            let scene = self.scene(n)?;
            let previous = (n > 1).then(|| self.scene(n - 1)).transpose()?;
            let next = n.checked_add(1).map(|p| self.scene(p)).transpose()?;
            let prepared = prepare(&scene, registry, self.base_dir, self.opts).map_err(|e| e.to_string())?;
            for w in prepared.stage().setup_warnings() {
                eprintln!("{w}");
            }
            if !told {
                told = true;
                for w in prepared.texture_warnings() {
                    eprintln!("warning: {w}");
                }
                if !prepared.info().is_empty() {
                    eprintln!("info: {}", prepared.info());
                }
            }
            let mut out = prepared.render(self.opts, &|_, _| {}, &job::CANCEL);
            let neighbours = Neighbours {
                previous: previous.as_ref(),
                next: next.as_ref(),
            };
            for w in frame::run_flow(&scene, &prepared, &mut out, &displays, neighbours)
                .map_err(|e| e.to_string())?
            {
                eprintln!("{w}");
            }
            let mut attributes = vec![("obscura:projection", scene.projection.clone())];
            attributes
                .extend(frame::header_attributes(&scene, &prepared, Some(n)).map_err(|e| e.to_string())?);
            let mut written =
                job::write_displays(&displays, &out, scene.camera.format.pixel_aspect, &attributes)
                    .map_err(|e| e.to_string())?;
            let cancelled = out.stats.cancelled;
            written.extend(frame::write_sidecars(
                &scene,
                &prepared,
                &displays,
                Some(n),
                cancelled,
            )?);
            if let Some(w) = out.stats.contract.warning(&scene.projection) {
                eprintln!("{w}");
            }
            if cancelled {
                return Err(format!(
                    "interrupted in frame {n}: its files are marked incomplete; run the same command again to resume"
                ));
            }
            if !self.quiet {
                outln!(
                    "frame {n}: {:.2} s (flow {:.3} s), wrote {}",
                    out.stats.render_seconds,
                    out.stats.flow_seconds,
                    written
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
        }
        registry.end_render();
        if !self.quiet && skipped > 0 {
            outln!("{skipped} complete frame(s) skipped");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aov_all_adds_the_ground_truth_and_the_texture_aovs() {
        let all = parse_aovs("all").unwrap();
        assert_eq!(&all[..10], &Aov::GROUND_TRUTH);
        assert_eq!(&all[10..], &[Aov::Albedo, Aov::Uv]);
        assert_eq!(parse_aovs("uv").unwrap(), [Aov::Uv]);
        let err = parse_aovs("Cs").unwrap_err();
        assert!(err.ends_with("flowValid, albedo, uv, or all"), "{err}");
    }
}
