//! Simulates a plume and writes, for a few frames, the density projected along z as a PNG
//! (white smoke on black), to look at what the solver makes:
//! `cargo run --release -p blurlab-media --example smoke_preview -- OUT_DIR [RES] [FRAMES]`.

use media::{SmokeSettings, SmokeSimulation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = std::path::PathBuf::from(args.get(1).ok_or("usage: smoke_preview OUT_DIR [RES] [FRAMES]")?);
    let res: usize = args.get(2).map_or(Ok(64), |s| s.parse())?;
    let frames: usize = args.get(3).map_or(Ok(60), |s| s.parse())?;
    std::fs::create_dir_all(&out)?;
    let mut sim =
        SmokeSimulation::new(SmokeSettings { resolution: [res, res * 3 / 2, res], ..SmokeSettings::default() })?;
    let started = std::time::Instant::now();
    let mut tiles = Vec::new();
    for f in 1..=frames {
        let grid = sim.next_frame();
        if f % (frames / 6).max(1) == 0 {
            let [nx, ny, nz] = grid.dims();
            let mut img = image::GrayImage::new(nx as u32, ny as u32);
            for j in 0..ny {
                for i in 0..nx {
                    let optical: f32 = (0..nz).map(|k| grid.voxel(i, j, k)).sum::<f32>() * 0.15;
                    let v = (1.0 - (-optical).exp()) * 255.0;
                    img.put_pixel(i as u32, (ny - 1 - j) as u32, image::Luma([v as u8]));
                }
            }
            tiles.push(img);
        }
        let (iterations, residual) = sim.last_solve();
        eprintln!(
            "frame {f}: {iterations} CG iterations, residual {residual:.1e}, {:.1} s",
            started.elapsed().as_secs_f64()
        );
    }
    let (w, h) = (tiles[0].width(), tiles[0].height());
    let mut strip = image::GrayImage::new(w * tiles.len() as u32, h);
    for (n, t) in tiles.iter().enumerate() {
        image::imageops::replace(&mut strip, t, i64::from(w) * n as i64, 0);
    }
    strip.save(out.join("smoke-preview.png"))?;
    Ok(())
}
