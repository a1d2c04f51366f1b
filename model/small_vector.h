#pragma once
// Private to rocklab::model: SUNDIALS vector operations for a state of 1 to
// 4 numbers. The vector keeps the serial N_Vector's content (length, data)
// and its clone/destroy; the arithmetic operations are replaced by loops of
// a length known at compile time, which the compiler unrolls, without the
// serial operations' special-case branches. On a 2-element state CVODE's and
// ARKODE's vector calls are a third of the step's cost
// (docs/performance.md, "Work and precision").

struct _generic_N_Vector;

namespace rocklab::model::detail {

/// Replaces the operations of `serial` (an N_VNew_Serial vector of length 1
/// to 4) by fixed-length ones; clones made from it carry them. Returns false
/// (and changes nothing) for another length.
bool UseSmallVectorOps(_generic_N_Vector* serial);

}  // namespace rocklab::model::detail
