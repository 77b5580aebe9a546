use super::*;
pub fn read_reference_image(_p: &Path, _s: (u32, u32)) -> Result<LoadedReference, TraceError> {
    unimplemented!()
}
pub fn read_truth_image(_p: &Path, _s: (u32, u32)) -> Result<TruthImage, TraceError> {
    unimplemented!()
}
pub fn write_reference_image(_p: &Path, _i: &SampleImage, _s: SlopeSource) -> Result<(), TraceError> {
    unimplemented!()
}
pub fn write_truth_image(_p: &Path, _t: &TruthImage) -> Result<(), TraceError> {
    unimplemented!()
}
