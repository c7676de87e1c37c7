//! Supersampling: `n x n` sample points per pixel at the centres of its cells, each with its
//! own interval list, averaged: the box pixel filter the tracer integrates, which one sample
//! point per pixel (the paper's setting) aliases at edges, texture and the horizon. It is the
//! frame rendered at `n` times the width and height through the same sensor, then each
//! `n x n` block averaged: sample point `(i, j)` of pixel `(x, y)` is the large image's pixel
//! `(n x + i, n y + j)`, whose centre is `(x + (i + 0.5) / n, y + (j + 0.5) / n)`. The f64
//! rasterizer, the GPU kernel and its twin therefore share it; what must stay the output
//! pixel's is set there: texture footprints (the pixel's angle, as the tracer filters all of
//! a pixel's samples with it) and the shading's sample sequence (the points of a block draw
//! consecutive samples of their output pixel's one sequence, so together they stay
//! stratified).

use std::borrow::Cow;

use study::scene::FrameScene;

use crate::io::LinearImage;

/// `scene` with every view's image `n` times as wide and high (the same sensor); borrowed
/// unchanged for `n = 1`.
pub fn scaled(scene: &FrameScene, n: u32) -> Cow<'_, FrameScene> {
    if n <= 1 {
        return Cow::Borrowed(scene);
    }
    let mut s = scene.clone();
    for view in &mut s.views {
        view.camera.width *= n;
        view.camera.height *= n;
    }
    Cow::Owned(s)
}

/// The mean of each `n x n` block of `image` (whose sides are multiples of `n`), summed in
/// f64 in row order.
pub fn downsample(image: &LinearImage, n: u32) -> LinearImage {
    if n <= 1 {
        return image.clone();
    }
    let (width, height) = (image.width / n, image.height / n);
    let weight = 1.0 / f64::from(n * n);
    let mut pixels = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            let mut sum = [0.0f64; 3];
            for j in 0..n {
                for i in 0..n {
                    let p = image.get(n * x + i, n * y + j);
                    for c in 0..3 {
                        sum[c] += f64::from(p[c]);
                    }
                }
            }
            pixels.push(sum.map(|v| (v * weight) as f32));
        }
    }
    LinearImage { width, height, pixels }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_average_and_one_is_the_identity() {
        let image = LinearImage { width: 4, height: 2, pixels: (0..8).map(|i| [i as f32, 1.0, 0.0]).collect() };
        let half = downsample(&image, 2);
        assert_eq!((half.width, half.height), (2, 1));
        // Block (0, 0) holds pixels 0, 1, 4, 5; block (1, 0) holds 2, 3, 6, 7.
        assert_eq!(half.pixels, vec![[2.5, 1.0, 0.0], [4.5, 1.0, 0.0]]);
        assert_eq!(downsample(&image, 1), image);
    }
}
