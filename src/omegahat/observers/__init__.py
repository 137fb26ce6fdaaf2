"""Angular-velocity estimators, one module each, each naming its source."""
