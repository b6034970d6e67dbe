//! The 11 backgrounds a composition can be set on: plain white and ten photographs, all free to
//! redistribute (CC0 or public domain; file, source, author and licence in
//! `fixtures/README.md`). They are compiled into the binary, served as versioned static assets
//! (`/static/bg-NAME.jpg?v=…`) and embedded as data URIs in the server's SVG and PNG renders.

/// One background.
#[derive(Debug, Clone, Copy)]
pub struct Background {
    /// The name a document uses (`"background": "grass"`).
    pub name: &'static str,
    /// What a drop-down shows.
    pub label: &'static str,
    /// The JPEG, or `None` for plain white.
    pub jpeg: Option<&'static [u8]>,
}

impl Background {
    /// The static asset's file name (`bg-grass.jpg`), when there is an image.
    pub fn asset_name(&self) -> Option<String> {
        self.jpeg.map(|_| format!("bg-{}.jpg", self.name))
    }
}

macro_rules! photo {
    ($name:literal, $label:literal) => {
        Background {
            name: $name,
            label: $label,
            jpeg: Some(include_bytes!(concat!(
                "../../../fixtures/backgrounds/",
                $name,
                ".jpg"
            ))),
        }
    };
}

/// Every background, `blank` first (the default of a new canvas).
pub const BACKGROUNDS: &[Background] = &[
    Background {
        name: "blank",
        label: "Blank (white)",
        jpeg: None,
    },
    photo!("grass", "Grass"),
    photo!("gravel", "Gravel"),
    photo!("brick", "Brick wall"),
    photo!("space", "Deep space (Hubble)"),
    photo!("rocket", "Rocket launch"),
    photo!("astronaut", "Astronaut"),
    photo!("coffee", "Coffee cup"),
    photo!("cat", "Cat"),
    photo!("camera", "Cameraman"),
    photo!("coins", "Coins"),
];

/// The OpenAPI schema of a background name: a string from [`BACKGROUNDS`].
pub struct BackgroundName;

impl utoipa::PartialSchema for BackgroundName {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{ObjectBuilder, SchemaType, Type};
        ObjectBuilder::new()
            .schema_type(SchemaType::Type(Type::String))
            .enum_values(Some(BACKGROUNDS.iter().map(|b| b.name)))
            .description(Some(
                "A background: `blank` (white) or one of ten photographs.",
            ))
            .into()
    }
}

impl utoipa::ToSchema for BackgroundName {
    fn name() -> std::borrow::Cow<'static, str> {
        std::borrow::Cow::Borrowed("BackgroundName")
    }
}

/// The background called `name`.
pub fn by_name(name: &str) -> Option<&'static Background> {
    BACKGROUNDS.iter().find(|b| b.name == name)
}

/// The background whose static asset is `file` (`bg-grass.jpg`).
pub fn by_asset(file: &str) -> Option<&'static Background> {
    let name = file.strip_prefix("bg-")?.strip_suffix(".jpg")?;
    by_name(name).filter(|b| b.jpeg.is_some())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eleven_backgrounds_blank_and_ten_decodable_photos() {
        assert_eq!(BACKGROUNDS.len(), 11);
        assert!(by_name("blank").is_some_and(|b| b.jpeg.is_none()));
        let mut total = 0;
        for b in BACKGROUNDS.iter().filter(|b| b.jpeg.is_some()) {
            let bytes = b.jpeg.unwrap_or_default();
            total += bytes.len();
            let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Jpeg)
                .unwrap_or_else(|e| panic!("{}: {e}", b.name));
            assert!(img.width() <= 1024 && img.width() >= 256, "{}", b.name);
            let asset = b.asset_name().unwrap_or_default();
            assert_eq!(by_asset(&asset).map(|x| x.name), Some(b.name));
        }
        assert!(total <= 1_200_000, "{total} bytes of backgrounds");
        assert!(by_asset("bg-blank.jpg").is_none() && by_asset("bg-nope.jpg").is_none());
    }
}
