#pragma once
// The errors servokit reports live in the public API (servokit/errors.h), so that a library user
// catches the same classes that every folder throws; this is their name inside the toolkit.
#include "servokit/errors.h"
