//! Storage: the database (SQLite or PostgreSQL behind one pool and one migration set), the
//! direct SQLite connection of the answer path, the answer writer that batches durable writes,
//! and the typed ids. The store knows no study, flow or web types: the worker flow hands it
//! requests through [`answer_writer::batched::Batched`].

pub mod answer_writer;
pub mod db;
pub mod ids;
pub mod sqlite_direct;
