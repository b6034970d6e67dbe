//! The answer-path benchmark's library and studies: solid-colour items, so that it needs no
//! fixture files, and a fresh study per phase with slots enough for the phase.

use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::StudyId;
use crate::studies::library::{self, NewItem};
use crate::studies::study::{self, StudySettings};

/// A solid-colour item so the benchmark does not depend on fixture files.
fn swatch(i: usize) -> NewItem {
    let colour = [
        (i * 37 % 256) as u8,
        (i * 91 % 256) as u8,
        (i * 53 % 256) as u8,
    ];
    NewItem {
        name: format!("swatch-{i}"),
        style: Some(format!("group-{}", i % 4)),
        tags: Vec::new(),
        image: image::RgbImage::from_pixel(400, 400, image::Rgb(colour)),
        cutout: None,
        svg: None,
    }
}

/// Items of the benchmark's library.
const BENCH_ITEMS: usize = 96;

pub(crate) async fn prepare(db: &Db, workers: usize, seconds: u64) -> Result<StudyId> {
    let lib = library::ensure_library(db, "bench").await?;
    // 96 items: 428,640 distinct triplets (n(n-1)(n-2)/2: a triplet is an anchor and an
    // unordered pair), more than the largest study below asks for.
    let have = library::list_items(db, lib).await?.len();
    if have < BENCH_ITEMS {
        for i in have..BENCH_ITEMS {
            if let library::Inserted::Unusable(why) =
                library::insert_item(db, lib, swatch(i)).await?
            {
                return Err(AppError::Internal(format!("bench swatch {i}: {why}")));
            }
        }
    }
    // Two HITs for every worker plus headroom for ~18,000 answers/s (the SQLite closed loop
    // reaches ~13,500 on 2 cores): running out of free slots mid-phase would turn answers into
    // refused starts and flatter the figures.
    let tuples = (workers * 90 + (seconds as usize) * 18_000).min(400_000) as u32;
    let settings = StudySettings {
        training_questions: 0,
        tuples,
        seed: crate::store::db::now_ms() as u64,
        ..StudySettings::default()
    };
    Ok(
        study::create(db, &format!("bench {workers}"), lib, settings)
            .await?
            .0,
    )
}
