//! Errors the API answers with: an HTTP status and a JSON body `{"error": {"code", "message"}}`
//! whose `code` is stable (the page and scripts branch on it; the message is for people).

use axum::Json;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};

/// Stable error codes of the API (documented in `openapi.json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Code {
    /// A query parameter or body is missing or malformed.
    BadRequest,
    /// The place is outside the GRIDMET box of the data.
    OutsideData,
    /// The day is outside the days the GRIDMET files hold (or lacks the input window).
    NoWeather,
    /// The place has no fuel (water, rock, developed land): no fire can start there.
    NoFuel,
    /// No trained forecaster or agent is available (run the demo or name one).
    NoModel,
    /// No such run, artifact, job or environment.
    NotFound,
    /// The request needs the token (non-loopback address).
    Unauthorized,
    /// A state-changing request from another origin.
    CrossOrigin,
    /// The job queue or the simulation slots are full.
    Busy,
    /// The body is larger than allowed.
    TooLarge,
    /// Something failed inside FireCast (reading files, a model).
    Internal,
}

impl Code {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::BadRequest => "bad_request",
            Self::OutsideData => "outside_data",
            Self::NoWeather => "no_weather",
            Self::NoFuel => "no_fuel",
            Self::NoModel => "no_model",
            Self::NotFound => "not_found",
            Self::Unauthorized => "unauthorized",
            Self::CrossOrigin => "cross_origin",
            Self::Busy => "busy",
            Self::TooLarge => "too_large",
            Self::Internal => "internal",
        }
    }

    fn status(self) -> StatusCode {
        match self {
            Self::BadRequest | Self::OutsideData | Self::NoWeather | Self::NoFuel => StatusCode::BAD_REQUEST,
            Self::NoModel => StatusCode::SERVICE_UNAVAILABLE,
            Self::NotFound => StatusCode::NOT_FOUND,
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::CrossOrigin => StatusCode::FORBIDDEN,
            Self::Busy => StatusCode::TOO_MANY_REQUESTS,
            Self::TooLarge => StatusCode::PAYLOAD_TOO_LARGE,
            Self::Internal => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }
}

/// An API error: a code and a sentence for the page.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{message}")]
pub struct ApiError {
    pub code: Code,
    pub message: String,
}

impl ApiError {
    pub fn new(code: Code, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }
    pub fn bad(message: impl Into<String>) -> Self {
        Self::new(Code::BadRequest, message)
    }
    pub fn not_found(message: impl Into<String>) -> Self {
        Self::new(Code::NotFound, message)
    }
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(Code::Internal, message)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = serde_json::json!({"error": {"code": self.code.as_str(), "message": self.message}});
        (self.code.status(), Json(body)).into_response()
    }
}

/// Errors starting the server (the CLI prints them).
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        addr: std::net::SocketAddr,
        #[source]
        source: std::io::Error,
    },
    #[error("{0}")]
    Config(String),
    #[error("server failed: {0}")]
    Io(#[from] std::io::Error),
}
