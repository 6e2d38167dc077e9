#pragma once
// The pieces of the one-line messages solvers write (SolveSummary::message, UsageError), in one
// place so that every solver spells numbers and option errors alike.
#include <string>

namespace servokit {

/// A number in a message, in its shortest form that reads back to the same double (1e-15 as
/// the user wrote it, a time to every digit that tells it apart).
std::string FormatNumber(double value);

/// Throws UsageError "<owner>::<field> = <value>: <rule>" unless `valid` (STYLE.md: the message
/// names the field, its value and the rule it breaks).
void RequireOption(bool valid,
                   const char* owner,
                   const char* field,
                   double value,
                   const std::string& rule);

}  // namespace servokit
