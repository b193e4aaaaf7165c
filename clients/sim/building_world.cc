// The building floor of scenario `building` (in progress).
