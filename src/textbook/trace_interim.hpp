#pragma once
// INTERIM until textbook::trace lands (helper T1): the fast trace under the textbook's names.
#include <smoketrace/trace/trace.hpp>
namespace smoketrace::textbook {
using smoketrace::trace;
}
