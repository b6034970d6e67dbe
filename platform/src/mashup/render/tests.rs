use super::*;
use crate::mashup::document::Piece;

/// A red disc filled through a gradient, so the drawing has an id (`g`) referenced by
/// `url(#g)`: two copies of it must not share that id.
const DISC: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">
<defs><linearGradient id="g"><stop offset="0" stop-color="#ff0000"/><stop offset="1" stop-color="#ee0000"/></linearGradient></defs>
<circle cx="50" cy="50" r="50" fill="url(#g)"/></svg>"##;

fn sources() -> Sources {
    let tree = learner::render::parse_svg(DISC.as_bytes()).expect("disc");
    let stored = tree.to_string(&usvg::WriteOptions::default());
    let mut blue = image::RgbImage::from_pixel(400, 400, image::Rgb([255, 255, 255]));
    for y in 100..300 {
        for x in 100..300 {
            blue.put_pixel(x, y, image::Rgb([0, 0, 255]));
        }
    }
    let mut png = Vec::new();
    blue.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("png");
    Sources::from([
        (ItemId(1), ItemSource::Svg(stored)),
        (ItemId(2), ItemSource::Png(png)),
    ])
}

fn piece(item: i64, x: f64, y: f64, scale: f64, rotation: f64) -> Piece {
    Piece {
        item: ItemId(item),
        x,
        y,
        scale,
        rotation,
    }
}

/// The same disc twice (one rotated and enlarged) and the raster square on the right.
fn document(background: &str) -> Document {
    let mut doc = Document::empty(400, 300, background);
    doc.pieces = vec![
        piece(1, 80.0, 80.0, 0.5, 0.0),
        piece(1, 200.0, 150.0, 0.75, 45.0),
        piece(2, 330.0, 80.0, 0.5, 0.0),
    ];
    doc
}

#[test]
fn the_svg_parses_and_nests_one_group_per_piece_without_duplicate_ids() {
    let text = svg(&document("grass"), &sources()).expect("svg");
    learner::render::parse_svg(text.as_bytes()).expect("usvg parses the export");
    let xml = usvg::roxmltree::Document::parse(&text).expect("XML");
    let pieces: Vec<_> = xml
        .descendants()
        .filter(|n| n.has_tag_name("g") && n.attribute("class") == Some("piece"))
        .collect();
    assert_eq!(pieces.len(), 3);
    assert_eq!(pieces[1].attribute("id"), Some("piece-1"));
    assert_eq!(pieces[2].attribute("data-item"), Some("2"));
    // The vector drawing is kept (a path, not a bitmap) in both copies of the disc.
    for p in &pieces[..2] {
        assert!(p.descendants().any(|n| n.has_tag_name("path")), "{text}");
    }
    assert!(pieces[2].descendants().any(|n| n.has_tag_name("image")));
    let mut ids: Vec<&str> = xml
        .descendants()
        .filter_map(|n| n.attribute("id"))
        .collect();
    let all = ids.len();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), all, "duplicate ids in {text}");
    assert!(
        ids.iter().any(|id| id.starts_with("p0-")) && ids.iter().any(|id| id.starts_with("p1-"))
    );
}

fn decode(png: &[u8]) -> image::RgbImage {
    image::load_from_memory_with_format(png, image::ImageFormat::Png)
        .expect("decodes")
        .to_rgb8()
}

#[test]
fn the_png_shows_pieces_where_they_are_and_the_background_elsewhere() {
    let img = decode(&png(&document("blank"), &sources()).expect("png"));
    assert_eq!(img.dimensions(), (400, 300));
    let red = |p: &image::Rgb<u8>| p[0] > 200 && p[1] < 40 && p[2] < 40;
    let blue = |p: &image::Rgb<u8>| p[0] < 40 && p[1] < 40 && p[2] > 200;
    assert!(red(img.get_pixel(80, 80)), "{:?}", img.get_pixel(80, 80));
    assert!(red(img.get_pixel(200, 150)));
    assert!(blue(img.get_pixel(330, 80)));
    // Rotation: the disc piece is round, the square raster is not; the enlarged disc's edge
    // reaches 60 px from its centre (160 × 0.75 / 2).
    assert!(red(img.get_pixel(200 + 55, 150)));
    assert!(!red(img.get_pixel(200 + 65, 150)));
    for (x, y) in [(5, 295), (395, 295), (5, 5), (330, 250)] {
        assert_eq!(img.get_pixel(x, y).0, [255, 255, 255], "({x}, {y})");
    }
    // A photograph behind: the empty corner is no longer plain white, the pieces still on top.
    let img = decode(&png(&document("grass"), &sources()).expect("png"));
    assert_ne!(img.get_pixel(5, 295).0, [255, 255, 255]);
    assert!(red(img.get_pixel(80, 80)));
}

#[test]
fn an_item_without_a_drawing_is_a_clear_error() {
    let mut doc = document("blank");
    doc.pieces.push(piece(99, 10.0, 10.0, 1.0, 0.0));
    let e = svg(&doc, &sources()).expect_err("no item 99");
    assert!(e.to_string().contains("item 99"), "{e}");
}
