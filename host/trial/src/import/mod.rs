//! Importers: foreign recordings of real pushes converted into trial logs (format version 2),
//! so every stage that reads a trial reads them unchanged. One module per source; each says
//! what it found out about its source's conventions and how.

pub mod zhou_mason;
