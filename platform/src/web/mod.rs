//! The web face: the JSON API and its OpenAPI document, the HTML pages of workers and admins,
//! static assets and the security policy, request extractors and admin sessions.

pub mod admin;
pub mod api;
pub mod assets;
pub mod extract;
pub mod pages;
