//! Writing images: format by extension, written beside the target and renamed
//! into place, so a failed write never leaves a half-written file.

use crate::file::PendingFile;
use std::io::Write;
use std::path::Path;

/// Why an image could not be written.
pub type OutputError = crate::file::FileError;

/// An output file being prepared: the temporary file exists from the start,
/// so an unwritable destination is reported before any rendering is done.
#[derive(Debug)]
pub struct PendingImage {
    file: PendingFile,
    format: image::ImageFormat,
}

impl PendingImage {
    /// Checks the format and reserves a temporary file next to `target`.
    pub fn create(target: &Path) -> Result<PendingImage, OutputError> {
        let name = target.display().to_string();
        let format = match target
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("png") => image::ImageFormat::Png,
            Some("ppm") | Some("pnm") => image::ImageFormat::Pnm,
            _ => {
                return Err(OutputError::Format {
                    path: name,
                    kind: "image",
                    choices: ".png or .ppm",
                })
            }
        };
        Ok(PendingImage {
            file: PendingFile::create(target)?,
            format,
        })
    }

    /// Encodes the pixels into the temporary file and renames it into place.
    pub fn finish(self, width: u32, height: u32, rgb: &[u8]) -> Result<(), OutputError> {
        encode(self.file.temp(), self.format, width, height, rgb)
            .map_err(|e| self.file.encode_error(e))?;
        self.file.rename()
    }
}

impl PendingImage {
    /// Starts writing a `width × height` image into the temporary file, to
    /// be given its rows from the top ([`ImageStream::write_rows`]): the
    /// encoder holds no more than the rows it is given.
    pub fn stream(self, width: u32, height: u32) -> Result<ImageStream, OutputError> {
        let io = |source| self.file.io_error(source);
        let file = std::fs::File::create(self.file.temp()).map_err(io)?;
        let writer = match self.format {
            image::ImageFormat::Pnm => {
                let mut file = std::io::BufWriter::new(file);
                // Binary PPM (`P6`), as the reference paper writes.
                write!(file, "P6\n{width} {height} 255\n").map_err(io)?;
                RowWriter::Ppm(file)
            }
            _ => {
                let encode = |e: png::EncodingError| self.file.encode_error(e);
                let mut encoder = png::Encoder::new(file, width, height);
                encoder.set_color(png::ColorType::Rgb);
                encoder.set_depth(png::BitDepth::Eight);
                // Fast deflate (the `image` crate's default), with every row
                // Paeth-filtered: choosing a filter per row, as `image` does,
                // cost more than the choice saved. Measured on the cube minus
                // a ball at 1024²: 0.99x the process's instructions, the file
                // 1.04x the size (Sub: 0.986x, 1.30x the size).
                encoder.set_compression(png::Compression::Fast);
                encoder.set_filter(png::Filter::Paeth);
                let header = encoder.write_header().map_err(encode)?;
                // No buffer of ours below the encoder: it writes whole
                // chunks, and every write's error reaches `finish`.
                RowWriter::Png(Box::new(header.into_stream_writer().map_err(encode)?))
            }
        };
        Ok(ImageStream {
            pending: self,
            writer,
        })
    }
}

/// An image being written row by row; renamed into place by
/// [`ImageStream::finish`], removed if dropped before.
pub struct ImageStream {
    pending: PendingImage,
    writer: RowWriter,
}

enum RowWriter {
    Png(Box<png::StreamWriter<'static, std::fs::File>>),
    Ppm(std::io::BufWriter<std::fs::File>),
}

impl std::fmt::Debug for ImageStream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ImageStream")
            .field("pending", &self.pending)
            .finish()
    }
}

impl ImageStream {
    /// Appends whole rows of 8-bit RGB.
    pub fn write_rows(&mut self, rgb: &[u8]) -> std::io::Result<()> {
        match &mut self.writer {
            RowWriter::Png(w) => w.write_all(rgb),
            RowWriter::Ppm(w) => w.write_all(rgb),
        }
    }

    /// Ends the file and renames it into place.
    pub fn finish(self) -> Result<(), OutputError> {
        let file = &self.pending.file;
        match self.writer {
            RowWriter::Png(w) => w.finish().map_err(|e| file.encode_error(e))?,
            RowWriter::Ppm(mut w) => w.flush().map_err(|source| file.io_error(source))?,
        }
        self.pending.file.rename()
    }
}

/// Encodes RGB pixels: PNG, or binary PPM (`P6`, as the reference paper
/// writes; the `image` crate's default PNM flavour would be PAM).
fn encode(
    path: &Path,
    format: image::ImageFormat,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> image::ImageResult<()> {
    use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
    use image::ImageEncoder;
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    match format {
        image::ImageFormat::Pnm => PnmEncoder::new(file)
            .with_subtype(PnmSubtype::Pixmap(SampleEncoding::Binary))
            .write_image(rgb, width, height, image::ExtendedColorType::Rgb8),
        _ => image::codecs::png::PngEncoder::new(file).write_image(
            rgb,
            width,
            height,
            image::ExtendedColorType::Rgb8,
        ),
    }
}
