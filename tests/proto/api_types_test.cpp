#include "proto/api_types.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace tracemesh::proto {
namespace {

/// A lookup over fixed fields, as a form or a query string would give.
field_lookup fields(std::map<std::string, std::string, std::less<>> values) {
  return [values = std::move(values)](std::string_view name) -> std::optional<std::string> {
    const auto found = values.find(name);
    if (found == values.end()) return std::nullopt;
    return found->second;
  };
}

void expect_invalid_naming(const result<mesh_params>& parsed, const std::string& field) {
  ASSERT_FALSE(parsed) << "expected an error naming " << field;
  EXPECT_EQ(parsed.error().code(), errc::invalid_argument);
  EXPECT_EQ(parsed.error().message().rfind(field, 0), 0U) << parsed.error().message();
  EXPECT_EQ(parsed.error().message().find('\n'), std::string::npos);
}

// ---------------------------------------------------------------------------------------------------------------
// parse_parameter_number

TEST(ParseParameterNumber, AcceptsDecimalNumbers) {
  const std::pair<const char*, double> cases[] = {
      {"1", 1.0},     {"1.0", 1.0},     {"-1", -1.0},     {"0.05", 0.05}, {"2e-3", 2e-3},
      {"1E2", 100.0}, {"-0.5", -0.5},   {".5", 0.5},      {"5.", 5.0},    {"000.25", 0.25},
  };
  for (const auto& [text, expected] : cases) {
    const result<double> value = parse_parameter_number("x", text);
    ASSERT_TRUE(value) << text << ": " << value.error().message();
    EXPECT_EQ(*value, expected) << text;
  }
}

TEST(ParseParameterNumber, EqualNumbersAreEqualDoubles) {
  for (const char* spelling : {"1", "1.0", "1.00000", "1e0", "10e-1", "0.1e1", "01"}) {
    const result<double> value = parse_parameter_number("density", spelling);
    ASSERT_TRUE(value) << spelling;
    EXPECT_EQ(*value, 1.0) << spelling;
    EXPECT_EQ(canonical_number(*value), "1") << spelling;
  }
}

TEST(ParseParameterNumber, RejectsEverythingElse) {
  for (const char* text : {"", " 1", "1 ", "+1", "1,5", "1.5.2", "1e", "abc", "1abc", "0x10", "0x1p3", "nan",
                           "NaN", "-nan", "inf", "-inf", "infinity", "1e999", "--1", "1\n", "\t1"}) {
    const result<double> value = parse_parameter_number("t0", text);
    ASSERT_FALSE(value) << '"' << text << '"';
    EXPECT_EQ(value.error().code(), errc::invalid_argument);
    EXPECT_EQ(value.error().message().rfind("t0: ", 0), 0U) << value.error().message();
    EXPECT_EQ(value.error().message().find('\n'), std::string::npos) << "control bytes are not echoed";
  }
}

TEST(ParseParameterNumber, HandlesHugeInputsWithShortMessages) {
  const std::string huge(1 << 20, '7');  // a finite 1,048,576-digit number overflows double
  const result<double> value = parse_parameter_number("density", huge + "x");
  ASSERT_FALSE(value);
  EXPECT_LT(value.error().message().size(), 200U);
}

// ---------------------------------------------------------------------------------------------------------------
// parse_mesh_params

TEST(ParseMeshParams, MissingFieldsKeepTheDefaults) {
  const result<mesh_params> parsed = parse_mesh_params(fields({}));
  ASSERT_TRUE(parsed) << parsed.error().message();
  const mesh_params defaults;
  EXPECT_EQ(parsed->density, defaults.density);
  EXPECT_EQ(parsed->d, defaults.d);
  EXPECT_EQ(parsed->t0, defaults.t0);
  EXPECT_EQ(parsed->method, defaults.method);
  EXPECT_EQ(parsed->refine, defaults.refine);
  EXPECT_EQ(parsed->trace.legendre_degree, defaults.trace.legendre_degree);
  EXPECT_EQ(parsed->trace.step_fraction, defaults.trace.step_fraction);
  EXPECT_EQ(parsed->trace.cos_bound, defaults.trace.cos_bound);
  EXPECT_EQ(parsed->trace.extreme_tolerance, defaults.trace.extreme_tolerance);
}

TEST(ParseMeshParams, ReadsMethodRefineAndTheTraceParameters) {
  const result<mesh_params> parsed =
      parse_mesh_params(fields({{"method", "trace"}, {"refine", "none"}, {"trace_degree", "12"},
                                {"trace_step", "0.25"}, {"trace_cos_bound", "0.95"},
                                {"trace_extreme_tolerance", "1e-2"}}));
  ASSERT_TRUE(parsed) << parsed.error().message();
  EXPECT_EQ(parsed->method, mesh_method::trace);
  EXPECT_EQ(parsed->refine, refine_mode::none);
  EXPECT_EQ(parsed->trace.legendre_degree, 12);
  EXPECT_EQ(parsed->trace.step_fraction, 0.25);
  EXPECT_EQ(parsed->trace.cos_bound, 0.95);
  EXPECT_EQ(parsed->trace.extreme_tolerance, 0.01);
  const result<mesh_params> lattice = parse_mesh_params(fields({{"method", "lattice"}, {"refine", "full"}}));
  ASSERT_TRUE(lattice);
  EXPECT_EQ(lattice->method, mesh_method::lattice);
  EXPECT_EQ(lattice->refine, refine_mode::full);
}

TEST(ParseMeshParams, TraceDegreeIsAWholeNumberInAnySpelling) {
  for (const char* spelling : {"10", "10.0", "1e1", "010", "100e-1"}) {
    const result<mesh_params> parsed = parse_mesh_params(fields({{"trace_degree", spelling}}));
    ASSERT_TRUE(parsed) << spelling << ": " << parsed.error().message();
    EXPECT_EQ(parsed->trace.legendre_degree, 10) << spelling;
  }
  using r = parameter_ranges;
  for (const int degree : {r::min_legendre_degree, r::max_legendre_degree}) {
    const result<mesh_params> parsed = parse_mesh_params(fields({{"trace_degree", std::to_string(degree)}}));
    ASSERT_TRUE(parsed) << degree;
    EXPECT_EQ(parsed->trace.legendre_degree, degree);
  }
  for (const char* text : {"10.5", "2.0000001", "1", "31", "-10", "1e300", "-1e300", "1e999", "ten", "", "nan"}) {
    expect_invalid_naming(parse_mesh_params(fields({{"trace_degree", text}})), "trace_degree");
  }
}

TEST(ParseMeshParams, MethodAndRefineAreExactLowerCaseNames) {
  for (const char* text : {"Trace", "LATTICE", " trace", "trace ", "", "tmsmesh", "trace\n"}) {
    expect_invalid_naming(parse_mesh_params(fields({{"method", text}})), "method");
  }
  for (const char* text : {"Full", "NONE", "yes", "0", "", "full;"}) {
    expect_invalid_naming(parse_mesh_params(fields({{"refine", text}})), "refine");
  }
  const result<mesh_params> bad = parse_mesh_params(fields({{"method", std::string(5000, 'x') + "\x01"}}));
  ASSERT_FALSE(bad);
  EXPECT_LT(bad.error().message().size(), 200U) << "the echoed value is cut";
  EXPECT_EQ(bad.error().message().find('\x01'), std::string::npos);
}

TEST(ParseMeshParams, TraceParametersOutOfRangeNameTheirField) {
  using r = parameter_ranges;
  const std::pair<const char*, double> bad[] = {
      {"trace_step", r::min_trace_step_fraction / 2},  {"trace_step", r::max_trace_step_fraction * 2},
      {"trace_cos_bound", r::min_trace_cos_bound - 0.1}, {"trace_cos_bound", 1.0},
      {"trace_extreme_tolerance", 0.0},                 {"trace_extreme_tolerance", r::max_extreme_tolerance * 2}};
  for (const auto& [field, value] : bad) {
    // Validated whatever the method: a request that is wrong for the trace method is wrong for the lattice one.
    for (const char* method : {"trace", "lattice"}) {
      expect_invalid_naming(parse_mesh_params(fields({{"method", method}, {field, canonical_number(value)}})), field);
    }
  }
  expect_invalid_naming(parse_mesh_params(fields({{"trace_step", "inf"}})), "trace_step");
  expect_invalid_naming(parse_mesh_params(fields({{"trace_cos_bound", "0x1p-1"}})), "trace_cos_bound");
  expect_invalid_naming(parse_mesh_params(fields({{"trace_extreme_tolerance", "1e-2 "}})), "trace_extreme_tolerance");
  const result<mesh_params> ends = parse_mesh_params(
      fields({{"trace_step", canonical_number(r::max_trace_step_fraction)},
              {"trace_cos_bound", canonical_number(r::min_trace_cos_bound)},
              {"trace_extreme_tolerance", canonical_number(r::min_extreme_tolerance)}}));
  ASSERT_TRUE(ends) << ends.error().message();
  EXPECT_EQ(ends->trace.step_fraction, r::max_trace_step_fraction);
}

TEST(ParseMeshParams, TheFieldListNamesEveryFieldRead) {
  // A lookup that records what parse_mesh_params asks for: exactly mesh_parameter_fields.
  std::vector<std::string> asked;
  const field_lookup recorder = [&asked](std::string_view name) -> std::optional<std::string> {
    asked.emplace_back(name);
    return std::nullopt;
  };
  ASSERT_TRUE(parse_mesh_params(recorder));
  EXPECT_EQ(asked, std::vector<std::string>(mesh_parameter_fields.begin(), mesh_parameter_fields.end()));
  std::vector<std::string> request(mesh_parameter_fields.begin(), mesh_parameter_fields.end());
  request.emplace_back("format");
  EXPECT_EQ(std::vector<std::string>(mesh_request_fields.begin(), mesh_request_fields.end()), request);
}

TEST(ParseMeshParams, CavitiesIsKeepOrDropAndPartOfTheCanonicalSpellingOnlyWhenDropped) {
  const result<mesh_params> defaults = parse_mesh_params(fields({}));
  const result<mesh_params> keep = parse_mesh_params(fields({{"cavities", "keep"}}));
  const result<mesh_params> drop = parse_mesh_params(fields({{"cavities", "drop"}}));
  ASSERT_TRUE(defaults && keep && drop);
  EXPECT_EQ(defaults->cavities, cavity_mode::keep);
  EXPECT_EQ(drop->cavities, cavity_mode::drop);
  EXPECT_EQ(canonical_parameters(*keep), canonical_parameters(*defaults)) << "keep is the default";
  std::string drop_spelling = canonical_parameters(*drop);
  const std::size_t dropped = drop_spelling.find(";cavities=drop");
  ASSERT_NE(dropped, std::string::npos) << drop_spelling;
  EXPECT_EQ(drop_spelling.erase(dropped, std::strlen(";cavities=drop")), canonical_parameters(*defaults));
  for (const char* text : {"Drop", "remove", "", "drop "}) {
    expect_invalid_naming(parse_mesh_params(fields({{"cavities", text}})), "cavities");
  }
}

TEST(ParseMeshParams, ReadsEveryField) {
  const result<mesh_params> parsed = parse_mesh_params(fields({{"density", "2.5"}, {"d", "-0.5"}, {"t0", "0.75"}}));
  ASSERT_TRUE(parsed) << parsed.error().message();
  EXPECT_EQ(parsed->density, 2.5);
  EXPECT_EQ(parsed->d, -0.5);
  EXPECT_EQ(parsed->t0, 0.75);
}

TEST(ParseMeshParams, CanonicalSpellingsGiveIdenticalParameters) {
  const result<mesh_params> short_form = parse_mesh_params(fields({{"density", "1"}, {"d", "-1"}, {"t0", "1"}}));
  const result<mesh_params> long_form =
      parse_mesh_params(fields({{"density", "1.0"}, {"d", "-1.000"}, {"t0", "10e-1"}}));
  ASSERT_TRUE(short_form && long_form);
  EXPECT_EQ(canonical_parameters(*short_form), canonical_parameters(*long_form));
  EXPECT_EQ(canonical_parameters(*short_form), canonical_parameters(mesh_params{}));
  EXPECT_EQ(canonical_parameters(*short_form).rfind("density=1;d=-1;t0=1;method=", 0), 0U);
}

TEST(ParseMeshParams, RangeEndsAreAccepted) {
  using r = parameter_ranges;
  const result<mesh_params> low = parse_mesh_params(fields({{"density", canonical_number(r::min_density)},
                                                            {"d", canonical_number(r::min_d)},
                                                            {"t0", canonical_number(r::min_t0)}}));
  ASSERT_TRUE(low) << low.error().message();
  EXPECT_EQ(low->density, r::min_density);
  const result<mesh_params> high = parse_mesh_params(fields({{"density", canonical_number(r::max_density)},
                                                             {"d", canonical_number(r::max_d)},
                                                             {"t0", canonical_number(r::max_t0)}}));
  ASSERT_TRUE(high) << high.error().message();
  EXPECT_EQ(high->t0, r::max_t0);
}

TEST(ParseMeshParams, OutOfRangeValuesNameTheirField) {
  expect_invalid_naming(parse_mesh_params(fields({{"density", "0.01"}})), "density");
  expect_invalid_naming(parse_mesh_params(fields({{"density", "21"}})), "density");
  expect_invalid_naming(parse_mesh_params(fields({{"d", "1"}})), "d");
  expect_invalid_naming(parse_mesh_params(fields({{"d", "0"}})), "d");
  expect_invalid_naming(parse_mesh_params(fields({{"d", "-25"}})), "d");
  expect_invalid_naming(parse_mesh_params(fields({{"t0", "0"}})), "t0");
  expect_invalid_naming(parse_mesh_params(fields({{"t0", "-1"}})), "t0");
  expect_invalid_naming(parse_mesh_params(fields({{"t0", "1000"}})), "t0");
}

TEST(ParseMeshParams, UnparsableValuesNameTheirField) {
  expect_invalid_naming(parse_mesh_params(fields({{"density", "nan"}})), "density");
  expect_invalid_naming(parse_mesh_params(fields({{"d", ""}})), "d");
  expect_invalid_naming(parse_mesh_params(fields({{"t0", "1;drop"}})), "t0");
  // Only the bad field is blamed even when others are fine.
  expect_invalid_naming(parse_mesh_params(fields({{"density", "1"}, {"d", "-1"}, {"t0", "inf"}})), "t0");
}

TEST(ParseMeshParams, IgnoresFieldsItDoesNotKnow) {
  const result<mesh_params> parsed = parse_mesh_params(fields({{"threads", "banana"}, {"density", "3"}}));
  ASSERT_TRUE(parsed);
  EXPECT_EQ(parsed->density, 3.0);
  EXPECT_EQ(parsed->threads, mesh_params{}.threads);
}

// ---------------------------------------------------------------------------------------------------------------
// parse_mesh_request

TEST(ParseMeshRequest, FormatDefaultsAndParses) {
  const result<mesh_request> plain = parse_mesh_request(fields({}));
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->format, mesh_format::off);
  const result<mesh_request> fallback = parse_mesh_request(fields({}), mesh_format::draco);
  ASSERT_TRUE(fallback);
  EXPECT_EQ(fallback->format, mesh_format::draco);
  const result<mesh_request> draco = parse_mesh_request(fields({{"format", "draco"}, {"density", "2"}}));
  ASSERT_TRUE(draco);
  EXPECT_EQ(draco->format, mesh_format::draco);
  EXPECT_EQ(draco->params.density, 2.0);
}

TEST(ParseMeshRequest, BadFormatOrParameterIsInvalidArgument) {
  const result<mesh_request> format = parse_mesh_request(fields({{"format", "obj"}}));
  ASSERT_FALSE(format);
  EXPECT_EQ(format.error().code(), errc::invalid_argument);
  EXPECT_NE(format.error().message().find("format"), std::string::npos);
  const result<mesh_request> density = parse_mesh_request(fields({{"format", "off"}, {"density", "x"}}));
  ASSERT_FALSE(density);
  EXPECT_EQ(density.error().message().rfind("density", 0), 0U);
}

// ---------------------------------------------------------------------------------------------------------------
// canonical forms, error bodies, HTTP statuses, job states

TEST(CanonicalNumber, ShortestRoundTrip) {
  EXPECT_EQ(canonical_number(1.0), "1");
  EXPECT_EQ(canonical_number(-1.0), "-1");
  EXPECT_EQ(canonical_number(0.1), "0.1");
  EXPECT_EQ(canonical_number(-0.0), "0");
  EXPECT_EQ(canonical_number(1e-3), "0.001");
  for (const double value : {0.05, 1.0 / 3, 19.999999999999996, -0.05}) {
    const result<double> back = parse_parameter_number("x", canonical_number(value));
    ASSERT_TRUE(back);
    EXPECT_EQ(*back, value);
  }
}

TEST(CanonicalParameters, SpellsMethodRefineAndForTheTraceMethodItsParameters) {
  mesh_params lattice;
  lattice.method = mesh_method::lattice;
  lattice.refine = refine_mode::full;
  EXPECT_EQ(canonical_parameters(lattice), "density=1;d=-1;t0=1;method=lattice;refine=full");
  mesh_params trace;
  trace.method = mesh_method::trace;
  trace.refine = refine_mode::none;
  trace.trace.legendre_degree = 12;
  trace.trace.step_fraction = 0.25;
  trace.trace.cos_bound = 0.95;
  trace.trace.extreme_tolerance = 0.01;
  EXPECT_EQ(canonical_parameters(trace),
            "density=1;d=-1;t0=1;method=trace;refine=none;trace_degree=12;trace_step=0.25;trace_cos_bound=0.95;"
            "trace_extreme_tolerance=0.01");
  // The lattice method ignores the trace parameters, and so does its key.
  mesh_params lattice_tuned = lattice;
  lattice_tuned.trace = trace.trace;
  EXPECT_EQ(canonical_parameters(lattice_tuned), canonical_parameters(lattice));
}

TEST(CanonicalParameters, EveryParameterOfTheTraceMethodCounts) {
  mesh_params base;
  base.method = mesh_method::trace;
  std::vector<mesh_params> changed(6, base);
  changed[0].refine = base.refine == refine_mode::full ? refine_mode::none : refine_mode::full;
  changed[1].method = mesh_method::lattice;
  changed[2].trace.legendre_degree += 1;
  changed[3].trace.step_fraction = std::nextafter(base.trace.step_fraction, 1.0);
  changed[4].trace.cos_bound = std::nextafter(base.trace.cos_bound, 0.0);
  changed[5].trace.extreme_tolerance = std::nextafter(base.trace.extreme_tolerance, 1.0);
  for (std::size_t i = 0; i < changed.size(); ++i) {
    EXPECT_NE(canonical_parameters(changed[i]), canonical_parameters(base)) << i;
    const std::string text = canonical_parameters(changed[i]);
    // The canonical string parses back to the same parameters.
    std::map<std::string, std::string, std::less<>> parsed_fields;
    std::string_view rest = text;
    while (!rest.empty()) {
      const std::string_view pair = rest.substr(0, rest.find(';'));
      rest.remove_prefix(std::min(rest.size(), pair.size() + 1));
      parsed_fields[std::string(pair.substr(0, pair.find('=')))] = std::string(pair.substr(pair.find('=') + 1));
    }
    const result<mesh_params> back = parse_mesh_params(fields(parsed_fields));
    ASSERT_TRUE(back) << text << ": " << back.error().message();
    EXPECT_EQ(canonical_parameters(*back), text);
  }
}

TEST(CanonicalParameters, DistinguishesDifferentParameters) {
  mesh_params a, b;
  b.t0 = std::nextafter(1.0, 2.0);
  EXPECT_NE(canonical_parameters(a), canonical_parameters(b));
  b = a;
  b.threads = 7;
  EXPECT_EQ(canonical_parameters(a), canonical_parameters(b)) << "threads never changes the output";
}

TEST(ErrorBody, Shape) {
  const nlohmann::json body = error_body("invalid_argument", "density: out of range");
  ASSERT_TRUE(body.is_object());
  ASSERT_EQ(body.size(), 1U);
  ASSERT_TRUE(body.at("error").is_object());
  EXPECT_EQ(body.at("error").size(), 2U);
  EXPECT_EQ(body.at("error").at("code"), "invalid_argument");
  EXPECT_EQ(body.at("error").at("message"), "density: out of range");
  EXPECT_EQ(nlohmann::json::parse(body.dump()), body);
}

TEST(ErrorBody, FromStatusUsesTheStableCodeName) {
  const nlohmann::json body = error_body(status(errc::nothing_to_mesh, "no atom with radius > 0"));
  EXPECT_EQ(body.at("error").at("code"), "nothing_to_mesh");
  EXPECT_EQ(body.at("error").at("message"), "no atom with radius > 0");
}

TEST(ErrorBody, EscapesArbitraryBytes) {
  const nlohmann::json body = error_body("invalid_input", std::string("line 3: \"quote\" \\ \x01 tab\t"));
  const std::string text = body.dump();
  EXPECT_EQ(text.find('\x01'), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(text), body);
}

TEST(HttpStatus, MapsEveryErrorCode) {
  EXPECT_EQ(http_status(errc::ok), 200);
  EXPECT_EQ(http_status(errc::invalid_input), 400);
  EXPECT_EQ(http_status(errc::invalid_argument), 400);
  EXPECT_EQ(http_status(errc::nothing_to_mesh), 422);
  EXPECT_EQ(http_status(errc::limit_exceeded), 413);
  EXPECT_EQ(http_status(errc::cancelled), 503);
  EXPECT_EQ(http_status(errc::io_error), 500);
  EXPECT_EQ(http_status(errc::internal_error), 500);
}

TEST(JobState, NamesRoundTripAndFinalStates) {
  const job_state all[] = {job_state::queued, job_state::running, job_state::done, job_state::failed,
                           job_state::cancelled};
  for (const job_state state : all) {
    const result<job_state> parsed = parse_job_state(job_state_name(state));
    ASSERT_TRUE(parsed);
    EXPECT_EQ(*parsed, state);
  }
  EXPECT_FALSE(parse_job_state("finished"));
  EXPECT_FALSE(is_final(job_state::queued));
  EXPECT_FALSE(is_final(job_state::running));
  EXPECT_TRUE(is_final(job_state::done));
  EXPECT_TRUE(is_final(job_state::failed));
  EXPECT_TRUE(is_final(job_state::cancelled));
}

}  // namespace
}  // namespace tracemesh::proto
