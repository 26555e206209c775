// The analysis report: report.md (with SVG figures beside it) and a self-contained report.html.
#pragma once
#include "flight/hover_model.hpp"
#include <map>
#include <string>
#include "cfd/derivatives.hpp"
#include "core/aero_model.hpp"
#include "stability/analysis.hpp"
#include "trim/trim.hpp"

#include <vector>

namespace flapstab {

struct FloquetStudy;
struct RevolvingComparison;

struct ReportInputs {
  const Case* case_file = nullptr;
  const TrimResult* trim = nullptr;
  const DerivativeResult* derivatives = nullptr;
  const StabilityReport* stability = nullptr;
  const WrenchHistory* history = nullptr;  // loads over the trimmed cycle
  double wall_time_s = 0;
  const FloquetStudy* floquet = nullptr;          // time-periodic analysis (optional)
  const RevolvingComparison* revolving = nullptr; // equivalent revolving-wing flyer (optional)
  const ControlSummary* control = nullptr;        // the case's pitch feedback (optional)
  std::vector<std::string> notices;               // analyses skipped and why
  std::string extra_markdown;                     // further sections (the CFD stability study), before the notes
};

struct ReportFiles {
  std::string markdown, html;
  std::map<std::string, std::string> figures;  // file name (figures/x.svg) -> SVG text
  std::string figure_notice;                   // why figures are missing, if they are
};

ReportFiles build_report(const ReportInputs& in);
// The report's opening statement: stable or not, which modes, how fast, by which model, what the feedback does.
std::string report_verdict(const ReportInputs& in);

// Minimal Markdown -> HTML (headings, paragraphs, lists, pipe tables, `code`, **bold**, images
// replaced by the inline SVG of the same name) for the self-contained report.
std::string markdown_to_html(const std::string& md, const std::map<std::string, std::string>& figures,
                             const std::string& title);

}  // namespace flapstab
