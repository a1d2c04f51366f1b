#pragma once
/// @file
/// Kept so that code including the old name still builds: a recorded
/// rocking test (RockingRecord) is model/test_record.h. (record/ is the
/// recorder of live runs.)

#include "model/test_record.h"
