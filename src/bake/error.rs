//! [`BakeError`]: every way a bake fails, below everything else in `bake/`.

#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Encode { path: String, message: String },
    #[error("{0}")]
    Refused(String),
    /// A destination texgraph will not write (see [`crate::output`]).
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("the bake was interrupted")]
    Cancelled,
}

impl BakeError {
    /// The CLI exit code: 130 for an interrupted bake, 2 for everything else (I/O, a refused
    /// size, memory bound or destination).
    pub fn exit_code(&self) -> u8 {
        match self {
            BakeError::Cancelled => 130,
            BakeError::Io { .. }
            | BakeError::Encode { .. }
            | BakeError::Refused(_)
            | BakeError::Output(_) => 2,
        }
    }
}
