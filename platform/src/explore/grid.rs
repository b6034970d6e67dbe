//! A representative style's branch on the balanced grid (Garces et al. 2016 §6.5.2,
//! Algorithms 3–4): its members in the same style space as the taxonomy, a SOM of `M × N`
//! nodes then balanced so that each node shows one item and hides the rest behind it. Computed
//! on request (a branch is small enough), in a blocking thread.

use learner::explore::{BalanceParams, SomParams, balanced_grid};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::UNLABELLED;
use super::jobs::Job;
use super::taxonomy::TaxonomyResult;
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::cache::{Built, Key};
use crate::store::ids::ItemId;

/// Most nodes of a grid shown on a page.
pub const MAX_CELLS: usize = 2_500;

/// One node.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Cell {
    /// Row, from 0.
    pub row: usize,
    /// Column, from 0.
    pub col: usize,
    /// The item shown.
    pub shown: Option<ItemId>,
    /// The items hidden behind it.
    pub hidden: Vec<ItemId>,
}

/// A branch on the grid.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct BranchGrid {
    /// Rows `M`.
    pub rows: usize,
    /// Columns `N`.
    pub cols: usize,
    /// Members of the branch.
    pub members: usize,
    /// `rows × cols` nodes, row-major.
    pub cells: Vec<Cell>,
}

/// The default shape for `n` members: the largest square with at most `n` nodes (`⌊√n⌋²`).
pub fn default_shape(n: usize) -> (usize, usize) {
    let side = (n as f64).sqrt().floor() as usize;
    (side.max(1), side.max(1))
}

/// The representative `index` of a finished taxonomy job.
pub fn branch(job: &Job, index: usize) -> Result<(TaxonomyResult, usize)> {
    if job.kind != "taxonomy" {
        return Err(AppError::NotFound("taxonomy"));
    }
    let Some(result) = &job.result else {
        return Err(AppError::Conflict(format!(
            "exploration {} is {}: wait until it is done",
            job.id, job.status
        )));
    };
    let result: TaxonomyResult =
        serde_json::from_value(result.clone()).map_err(AppError::internal)?;
    if index >= result.representatives.len() {
        return Err(AppError::NotFound("representative style"));
    }
    Ok((result, index))
}

/// Lays out the members of representative `index` of `job` on an `rows × cols` grid (default
/// [`default_shape`]); `rows·cols` must not exceed the members.
pub async fn layout(
    state: &AppState,
    job: &Job,
    index: usize,
    shape: (Option<usize>, Option<usize>),
) -> Result<BranchGrid> {
    let (result, index) = branch(job, index)?;
    let members = result.representatives[index].members.clone();
    let n = members.len();
    let (rows, cols) = match shape {
        (None, None) => default_shape(n),
        (Some(r), Some(c)) => (r, c),
        _ => {
            return Err(AppError::BadRequest(
                "rows and cols: give both, or neither for the largest square".into(),
            ));
        }
    };
    if rows == 0 || cols == 0 {
        return Err(AppError::BadRequest("rows and cols: at least 1".into()));
    }
    let cells = rows.saturating_mul(cols);
    if cells > n || cells > MAX_CELLS {
        return Err(AppError::BadRequest(format!(
            "rows × cols = {cells}: at most the branch's {n} members and at most {MAX_CELLS}"
        )));
    }
    let built = state
        .search
        .get(
            &state.db,
            Key {
                library: job.library,
                model: job.model,
            },
        )
        .await?;
    let grid = tokio::task::spawn_blocking(move || arrange(&built, &members, rows, cols))
        .await
        .map_err(AppError::internal)??;
    Ok(grid)
}

/// Lays out `members` (items of `built`'s library) on an `rows × cols` balanced grid in
/// `built`'s style space (blocking: call it off the async runtime). The icon-set study's
/// explorer (`studies::iconset::explorer`) lays out every branch with it when the study is
/// created.
pub fn arrange(built: &Built, members: &[ItemId], rows: usize, cols: usize) -> Result<BranchGrid> {
    let n = members.len();
    let matrix = built.index.matrix();
    let dim = matrix.stride();
    let mut names: Vec<&str> = Vec::new();
    let (mut points, mut labels) = (Vec::with_capacity(n * dim), Vec::with_capacity(n));
    for id in members {
        let row = built
            .row_of(*id)
            .ok_or_else(|| AppError::Conflict(format!("item {id} is no longer in the library")))?;
        points.extend_from_slice(matrix.row(row));
        let label = built.styles[row].as_deref().unwrap_or(UNLABELLED);
        let l = match names.iter().position(|x| *x == label) {
            Some(l) => l,
            None => {
                names.push(label);
                names.len() - 1
            }
        };
        labels.push(l as u32);
    }
    let (grid, _) = balanced_grid(
        &points,
        dim,
        &labels,
        &SomParams::new(rows, cols),
        &BalanceParams::default(),
    )
    .map_err(|e| AppError::BadRequest(e.to_string()))?;
    Ok(BranchGrid {
        rows: grid.rows,
        cols: grid.cols,
        members: n,
        cells: grid
            .nodes
            .iter()
            .map(|node| Cell {
                row: node.row,
                col: node.col,
                shown: node.shown.map(|i| members[i]),
                hidden: node.hidden.iter().map(|&i| members[i]).collect(),
            })
            .collect(),
    })
}
