//! Scene export to OBJ and GLB.
