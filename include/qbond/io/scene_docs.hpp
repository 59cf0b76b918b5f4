#pragma once
/// The key tables of the scene docs, written from the declarations the scene reader reads by:
/// the force laws' parameters (laws/registry.hpp), the heuristic types (heuristics/registry.hpp),
/// the body types (the reader's table) and the integrators with their options (integrators.hpp). In a Markdown file each table sits between
/// `<!-- keys:NAME -->` and `<!-- /keys:NAME -->`; `qbond key-tables FILE…` rewrites them, as
/// `qbond schema` writes docs/scene.schema.json.
#include <string>
#include <string_view>
#include <vector>

namespace qbond {

/// The names of the tables a Markdown file may hold between markers.
std::vector<std::string_view> scene_doc_table_names();

/// One table, header and rows, each line ended by '\n'; std::invalid_argument for an unknown name.
std::string scene_doc_table(std::string_view name);

/// `markdown` with every marked table rewritten. std::invalid_argument naming `file` and the
/// line for an unknown table name or a marker left unclosed.
std::string with_scene_doc_tables(std::string_view markdown, std::string_view file);

}  // namespace qbond
