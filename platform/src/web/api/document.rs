//! The OpenAPI document: the operations, and the rules that complete them — the admin
//! authentication as `securitySchemes` and each admin operation's requirement, the error
//! statuses every operation of a kind shares, and what `StartRequest` needs that serde's
//! optional fields cannot say. The rules follow the server's own (the `Admin` extractor, the
//! `ApiJson` / `ApiPath` / `ApiQuery` extractors), so a new route cannot forget them.

use utoipa::openapi::path::{Operation, ParameterIn};
use utoipa::openapi::security::{ApiKey, ApiKeyValue, SecurityRequirement, SecurityScheme};
use utoipa::openapi::{ContentBuilder, Ref, RefOr, ResponseBuilder};
use utoipa::{Modify, OpenApi};

use super::{
    OkBody, admin, compositions, explore, iconset_worker, mashup_worker, models, quality, schema,
    search, settings, worker, workers,
};
use crate::error::ErrorBody;

/// The OpenAPI document.
#[derive(OpenApi)]
#[openapi(
    info(title = "Style rating-study platform", version = "1"),
    paths(
        super::healthz,
        worker::study_info,
        worker::start,
        worker::assignment_state,
        worker::training,
        worker::give_up,
        worker::answer,
        worker::reasons,
        mashup_worker::mashup_task,
        mashup_worker::mashup_search,
        mashup_worker::mashup_event,
        mashup_worker::mashup_submit,
        iconset_worker::iconset_task,
        iconset_worker::iconset_explorer,
        iconset_worker::iconset_search,
        iconset_worker::iconset_event,
        iconset_worker::iconset_submit,
        admin::admin_session,
        admin::admin_studies,
        admin::admin_create_study,
        admin::admin_study,
        admin::admin_dashboard,
        admin::admin_workers,
        admin::admin_report,
        admin::admin_audit,
        admin::admin_verify_code,
        admin::admin_export,
        quality::admin_qc,
        quality::admin_decision,
        quality::admin_curated,
        quality::admin_release,
        models::admin_models,
        models::admin_train,
        search::admin_search,
        search::admin_search_example,
        explore::admin_start_taxonomy,
        explore::admin_job,
        explore::admin_grid,
        explore::admin_start_map,
        explore::admin_map_view,
        compositions::create_composition,
        compositions::list_compositions,
        compositions::get_composition,
        compositions::update_composition,
        compositions::delete_composition,
        compositions::render_composition,
        compositions::export_composition,
        settings::admin_settings,
        settings::admin_edit_settings,
        settings::admin_settings_changes,
        workers::admin_block,
        workers::admin_add_bonus,
        workers::admin_bonuses
    ),
    components(schemas(
        ErrorBody,
        OkBody,
        schema::ReasonCode,
        schema::ExportFile,
        schema::Gender,
        schema::ArtExperience,
        schema::BlockedWorker,
        schema::ProlificCode
    )),
    modifiers(&AdminSecurity, &SharedResponses, &StartRequestShape)
)]
pub struct ApiDoc;

/// Name of the session-cookie security scheme.
const SESSION_SCHEME: &str = "session";
/// Name of the CSRF-header security scheme.
const CSRF_SCHEME: &str = "csrf";

/// Whether `method` changes state, by the rule of [`crate::web::admin::Admin`]'s CSRF check.
fn changes_state(method: &str) -> bool {
    !matches!(method, "get" | "head" | "options")
}

/// The operations of `path` with their (lowercase) methods.
fn operations(item: &mut utoipa::openapi::PathItem) -> Vec<(&'static str, &mut Operation)> {
    [
        ("get", item.get.as_mut()),
        ("put", item.put.as_mut()),
        ("post", item.post.as_mut()),
        ("delete", item.delete.as_mut()),
        ("options", item.options.as_mut()),
        ("head", item.head.as_mut()),
        ("patch", item.patch.as_mut()),
        ("trace", item.trace.as_mut()),
    ]
    .into_iter()
    .filter_map(|(m, op)| op.map(|op| (m, op)))
    .collect()
}

/// The admin authentication as `securitySchemes` (the session cookie, and the CSRF header
/// state-changing requests add), and on every admin operation its requirement: the rule is the
/// one [`crate::web::admin::Admin`] enforces (every route under `/api/v1/admin/` takes the extractor).
struct AdminSecurity;

impl Modify for AdminSecurity {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        let components = doc.components.get_or_insert_with(Default::default);
        components.add_security_scheme(
            SESSION_SCHEME,
            SecurityScheme::ApiKey(ApiKey::Cookie(ApiKeyValue::with_description(
                crate::web::admin::COOKIE,
                "The admin session: the cookie the login form `POST /admin/login` (fields \
                 `username`, `password`) sets; valid for 12 hours.",
            ))),
        );
        components.add_security_scheme(
            CSRF_SCHEME,
            SecurityScheme::ApiKey(ApiKey::Header(ApiKeyValue::with_description(
                "x-csrf-token",
                "The session's CSRF token (`csrf` of `GET /api/v1/admin/session`), required on \
                 every state-changing admin request.",
            ))),
        );
        for (path, item) in doc.paths.paths.iter_mut() {
            if !path.starts_with("/api/v1/admin/") {
                continue;
            }
            for (method, op) in operations(item) {
                let mut schemes = vec![SESSION_SCHEME];
                if changes_state(method) {
                    schemes.push(CSRF_SCHEME);
                }
                // One requirement naming both schemes: both are needed together.
                let requirement = schemes
                    .into_iter()
                    .fold(SecurityRequirement::default(), |r, s| {
                        r.add(s, Vec::<String>::new())
                    });
                op.security = Some(vec![requirement]);
            }
        }
    }
}

/// The error statuses operations share, added to each operation that does not describe them
/// itself, by the rules the server follows: 503 anywhere (database busy), 400 / 413 / 415 with
/// a JSON body ([`crate::web::extract::ApiJson`]), 400 with query parameters, 404 with path
/// parameters (an unknown or malformed id), 401 with the session requirement, 403 with the CSRF
/// one.
struct SharedResponses;

impl Modify for SharedResponses {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        for (_, item) in doc.paths.paths.iter_mut() {
            for (_, op) in operations(item) {
                let has = |op: &Operation, location: ParameterIn| {
                    op.parameters
                        .iter()
                        .flatten()
                        .any(|p| p.parameter_in == location)
                };
                let security = serde_json::to_string(&op.security).unwrap_or_default();
                let mut shared: Vec<(&str, &str)> =
                    vec![("503", "The database is busy or unreachable; retry later")];
                if op.request_body.is_some() {
                    shared.extend([
                        (
                            "400",
                            "The body is not JSON, not an object of the schema, or a field is \
                             invalid (the message names it)",
                        ),
                        (
                            "413",
                            "The body is larger than the server's limit (64 KiB by default)",
                        ),
                        ("415", "The body's Content-Type is not application/json"),
                    ]);
                }
                if has(op, ParameterIn::Query) {
                    shared.push(("400", "A query parameter is invalid"));
                }
                if has(op, ParameterIn::Path) {
                    shared.push(("404", "No such resource (or a malformed id in the path)"));
                }
                if security.contains(SESSION_SCHEME) {
                    shared.push(("401", "No valid admin session cookie"));
                }
                if security.contains(CSRF_SCHEME) {
                    shared.push(("403", "The x-csrf-token header is missing or wrong"));
                }
                for (status, description) in shared {
                    op.responses
                        .responses
                        .entry(status.to_string())
                        .or_insert_with(|| error_response(description));
                }
            }
        }
    }
}

/// `StartRequest` needs `worker_id` but in an MTurk preview (which has no workerId): the rule
/// of [`crate::flow::start`], which serde's optional field cannot say. The preview is an
/// `assignment_id` of `ASSIGNMENT_ID_NOT_AVAILABLE` with a `turk_submit_to` (which makes the
/// source MTurk unless another is named).
struct StartRequestShape;

impl Modify for StartRequestShape {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::schema::{
            AllOfBuilder, AnyOfBuilder, ObjectBuilder, SchemaType, Type,
        };
        let Some(schemas) = doc.components.as_mut().map(|c| &mut c.schemas) else {
            return;
        };
        let Some(fields) = schemas.remove("StartRequest") else {
            return;
        };
        let preview = ObjectBuilder::new()
            .required("assignment_id")
            .required("turk_submit_to")
            .property(
                "assignment_id",
                ObjectBuilder::new()
                    .schema_type(SchemaType::AnyValue)
                    .enum_values(Some([crate::flow::MTURK_PREVIEW])),
            )
            .property(
                "source",
                ObjectBuilder::new()
                    .schema_type(SchemaType::AnyValue)
                    .enum_values(Some([serde_json::json!("mturk"), serde_json::Value::Null])),
            );
        let shape = AnyOfBuilder::new()
            .item(ObjectBuilder::new().required("worker_id").property(
                "worker_id",
                ObjectBuilder::new().schema_type(SchemaType::Type(Type::String)),
            ))
            .item(preview)
            .description(Some("`worker_id` is required except in an MTurk preview"));
        let description = match &fields {
            RefOr::T(utoipa::openapi::Schema::Object(o)) => o.description.clone(),
            _ => None,
        };
        schemas.insert(
            "StartRequest".into(),
            AllOfBuilder::new()
                .item(fields)
                .item(shape)
                .description(description)
                .into(),
        );
    }
}

fn error_response(description: &str) -> RefOr<utoipa::openapi::Response> {
    ResponseBuilder::new()
        .description(description)
        .content(
            "application/json",
            ContentBuilder::new()
                .schema(Some(Ref::from_schema_name("ErrorBody")))
                .build(),
        )
        .build()
        .into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn admin_operations_name_their_security() {
        let doc = serde_json::to_value(ApiDoc::openapi()).expect("document as JSON");
        let schemes = &doc["components"]["securitySchemes"];
        assert_eq!(schemes["session"]["in"], "cookie");
        assert_eq!(schemes["session"]["name"], crate::web::admin::COOKIE);
        assert_eq!(schemes["csrf"]["in"], "header");
        assert_eq!(schemes["csrf"]["name"], "x-csrf-token");
        let paths = doc["paths"].as_object().expect("paths");
        for (path, item) in paths {
            for (method, op) in item.as_object().expect("path item") {
                let security = &op["security"];
                if path.starts_with("/api/v1/admin/") {
                    let expected = if method == "get" {
                        serde_json::json!([{"session": []}])
                    } else {
                        serde_json::json!([{"session": [], "csrf": []}])
                    };
                    assert_eq!(security, &expected, "{method} {path}");
                    assert!(op["responses"]["401"].is_object(), "{method} {path}");
                } else {
                    assert!(security.is_null(), "{method} {path} is public");
                }
                assert!(op["responses"]["503"].is_object(), "{method} {path}");
                if op["requestBody"].is_object() {
                    for status in ["400", "413", "415"] {
                        assert!(
                            op["responses"][status].is_object(),
                            "{method} {path} {status}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn reason_codes_and_their_count_follow_the_list() {
        let doc = serde_json::to_value(ApiDoc::openapi()).expect("document as JSON");
        let schemas = &doc["components"]["schemas"];
        let codes: Vec<&str> = crate::flow::REASONS.iter().map(|(_, c, _)| *c).collect();
        assert_eq!(schemas["ReasonCode"]["enum"], serde_json::json!(codes));
        // `max_items` is a literal in the attribute: it must be the list's length.
        assert_eq!(
            schemas["ReasonsRequest"]["properties"]["reasons"]["maxItems"],
            codes.len()
        );
        let files = schemas["ExportFile"]["enum"]
            .as_array()
            .expect("files")
            .len();
        assert_eq!(files, crate::studies::export::FILES.len());
    }
}
