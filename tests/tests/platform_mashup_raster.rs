//! Raster clip art on the mash-up canvas keeps its transparency (§5.7.3), through the real
//! server on SQLite and PostgreSQL: a PNG with a transparent surround (`fixtures/raster/`,
//! rendered from a Twemoji drawing by rsvg-convert), imported with `platform library import`
//! and uploaded on the admin page, is served as a cut-out for the canvas, embedded in the SVG
//! export as an RGBA PNG whose corners are transparent, and composited in the PNG export so
//! that a corner of the piece shows the background photograph, not a white square.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

both_databases!(raster_pieces, raster_sqlite, raster_postgres);

const FIXTURE: &str = "raster/twemoji-cat-face.png";

/// Every raster image embedded in an SVG document, decoded by usvg from its data URI.
fn embedded_pngs(svg: &str) -> Vec<image::RgbaImage> {
    fn walk(group: &usvg::Group, out: &mut Vec<image::RgbaImage>) {
        for node in group.children() {
            match node {
                usvg::Node::Group(g) => walk(g, out),
                usvg::Node::Image(img) => match img.kind() {
                    usvg::ImageKind::PNG(data) => out.push(
                        image::load_from_memory_with_format(data, image::ImageFormat::Png)
                            .expect("embedded PNG decodes")
                            .to_rgba8(),
                    ),
                    usvg::ImageKind::SVG(tree) => walk(tree.root(), out),
                    _ => {}
                },
                _ => {}
            }
        }
    }
    let tree = usvg::Tree::from_str(svg, &usvg::Options::default()).expect("usvg parses");
    let mut out = Vec::new();
    walk(tree.root(), &mut out);
    out
}

async fn raster_pieces(db: TestDb) {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::copy(e2e::fixture(FIXTURE), dir.path().join("cat.png")).expect("copy");
    import_named(&db.url, "clipart", dir.path(), None);
    create_admin(&db.url);
    let server = Server::start(&db.url);
    let c = client();
    let base = server.url("");
    let base = base.trim_end_matches('/');
    let (cookie, csrf) = admin_login(&c, base).await;

    // The same file uploaded on the admin page.
    let fixture = std::fs::read(e2e::fixture(FIXTURE)).expect("fixture");
    let boundary = "----e2e-raster-7f1";
    let mut body = Vec::new();
    for (name, value) in [("csrf", csrf.as_str()), ("library", "clipart")] {
        body.extend_from_slice(
            format!(
                "--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n{value}\r\n"
            )
            .as_bytes(),
        );
    }
    body.extend_from_slice(
        format!(
            "--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"uploaded.png\"\r\n\
             Content-Type: image/png\r\n\r\n"
        )
        .as_bytes(),
    );
    body.extend_from_slice(&fixture);
    body.extend_from_slice(format!("\r\n--{boundary}--\r\n").as_bytes());
    let resp = c
        .post(format!("{base}/admin/library/upload"))
        .header("cookie", &cookie)
        .header(
            "content-type",
            format!("multipart/form-data; boundary={boundary}"),
        )
        .body(body)
        .send()
        .await
        .expect("upload");
    assert_eq!(resp.status().as_u16(), 200);

    let (status, found) = send(
        c.get(format!(
            "{base}/api/v1/admin/search?library=clipart&limit=10"
        ))
        .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{found}");
    let ids: Vec<i64> = found["results"]
        .as_array()
        .expect("results")
        .iter()
        .map(|r| r["id"].as_i64().expect("id"))
        .collect();
    assert_eq!(ids.len(), 2, "{found}");

    // The fixture as the import fits it: 240 → 400 pixels, so its corner pixel (2, 237) is at
    // about (3, 395) of the cut-out; its centre is opaque.
    let original = image::load_from_memory(&fixture)
        .expect("fixture")
        .to_rgba8();
    assert_eq!(
        original.get_pixel(2, 237)[3],
        0,
        "the fixture's corner is transparent"
    );
    assert_eq!(original.get_pixel(120, 120)[3], 255);
    for &id in &ids {
        let media = |file: String| {
            let (c, cookie) = (c.clone(), cookie.clone());
            async move {
                let resp = c
                    .get(file)
                    .header("cookie", cookie)
                    .send()
                    .await
                    .expect("media");
                assert_eq!(resp.status().as_u16(), 200);
                resp.bytes().await.expect("bytes").to_vec()
            }
        };
        let cutout = media(format!("{base}/media/items/{id}.cutout.png")).await;
        let cutout = image::load_from_memory(&cutout)
            .expect("cut-out")
            .to_rgba8();
        assert_eq!(cutout.dimensions(), (400, 400));
        assert_eq!(
            cutout.get_pixel(3, 395)[3],
            0,
            "item {id}: the cut-out's corner"
        );
        assert_eq!(cutout.get_pixel(200, 200)[3], 255);
        // The rendering the features see stays opaque on white.
        let flat = media(format!("{base}/media/items/{id}.png")).await;
        let flat = image::load_from_memory(&flat).expect("png").to_rgba8();
        assert_eq!(flat.get_pixel(3, 395).0, [255, 255, 255, 255]);
    }

    // One piece of each on the grass: 160-pixel squares centred at (200, 300) and (600, 300).
    let piece =
        |item: i64, x: f64| json!({"item": item, "x": x, "y": 300, "scale": 1.0, "rotation": 0});
    let doc = json!({"version": 1, "width": 800, "height": 600, "background": "grass",
                     "pieces": [piece(ids[0], 200.0), piece(ids[1], 600.0)]});
    let bare =
        json!({"version": 1, "width": 800, "height": 600, "background": "grass", "pieces": []});
    let render = |format: &str, doc: &Value| {
        let req = c
            .post(format!(
                "{base}/api/v1/admin/compositions/render?format={format}"
            ))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"library": "clipart", "document": doc}));
        async move {
            let resp = req.send().await.expect("render");
            assert_eq!(resp.status().as_u16(), 200);
            resp.bytes().await.expect("bytes").to_vec()
        }
    };

    // SVG: each raster piece is an embedded PNG that kept its alpha.
    let svg = String::from_utf8(render("svg", &doc).await).expect("utf-8");
    let embedded = embedded_pngs(&svg);
    assert_eq!(embedded.len(), 2, "two raster pieces (the grass is a JPEG)");
    for png in embedded.iter().filter(|p| p.dimensions() == (400, 400)) {
        assert_eq!(png.get_pixel(3, 395)[3], 0, "an opaque square in the SVG");
        assert_eq!(png.get_pixel(200, 200)[3], 255);
    }

    // PNG: a piece's corner shows the grass exactly as the bare background does; its centre
    // shows the cat (the fixture's colour there).
    let with = image::load_from_memory(&render("png", &doc).await)
        .expect("png")
        .to_rgb8();
    let grass = image::load_from_memory(&render("png", &bare).await)
        .expect("png")
        .to_rgb8();
    let centre = original.get_pixel(120, 120);
    for x in [200_u32, 600] {
        // The piece spans x-80..x+80, 220..380: its bottom-left corner pixel.
        let (cx, cy) = (x - 79, 378);
        let (got, want) = (with.get_pixel(cx, cy).0, grass.get_pixel(cx, cy).0);
        let diff = got
            .iter()
            .zip(want)
            .map(|(a, b)| a.abs_diff(b))
            .max()
            .unwrap();
        assert!(
            diff <= 2,
            "corner of the piece at {x}: {got:?}, the grass is {want:?}"
        );
        assert!(
            want.iter().map(|&c| 255 - u32::from(c)).sum::<u32>() > 60,
            "the grass at the corner is not near-white: {want:?}"
        );
        let mid = with.get_pixel(x, 300).0;
        let diff = mid
            .iter()
            .zip(&centre.0[..3])
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        assert!(
            diff <= 8,
            "centre of the piece at {x}: {mid:?}, the cat is {centre:?}"
        );
    }
}
