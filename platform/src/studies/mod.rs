//! What an admin manages: item libraries, studies (settings, edits, pool creation, the
//! researcher-written consent and instructions in Markdown), the dashboard, exports, bonuses
//! and the trained style metric.

pub mod bonus;
pub mod dashboard;
pub mod export;
pub mod iconset;
pub mod kind;
pub mod library;
pub mod markdown;
pub mod mashup;
pub mod rating;
pub mod report;
pub mod study;
pub mod study_edit;
pub mod train;
